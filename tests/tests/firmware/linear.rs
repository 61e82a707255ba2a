//! The firmware's linear mode (issue 18.4): OSQP's quadcopter on the Cortex-M4F
//! (firmware-template/specs/quadcopter-m4f.toml: ADMM in f32, written), its own linear model
//! flown in closed loop under its state-feedback controller (firmware-template/src/linear.rs), and the
//! same loop on the host with the same generated module.

use super::*;
use flight_sim::{
    fly_linear, LinearController, LinearNoiseConfig, LinearPlant, LinearReference, LinearScenario,
    Setpoint,
};

mpc_macros::mpc!(mod quadcopter_m4f = "../firmware-template/specs/quadcopter-m4f.toml");
use quadcopter_m4f as q;

const QUADCOPTER_M4F: &str = "firmware-template/specs/quadcopter-m4f.toml";
/// Cycles flown in the test: 10 s of the yaw step at 0.1 s, as `scripts/firmware.sh --cycles 100` (each
/// cycle some 3e7 instructions).
const QUADCOPTER_CYCLES: usize = 100;

fn m4_quadcopter_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| {
        build_and_fly(
            M4,
            Some(QUADCOPTER_M4F),
            "quadcopter-m4f",
            Some(QUADCOPTER_CYCLES),
        )
    })
}

/// The host's run of the firmware's linear loop: the commands, the fallbacks, the final state.
struct HostRun {
    commands: Vec<[f32; q::NU]>,
    fallbacks: u64,
    state: [f64; q::NX],
}

/// The generated controller fed the exact state, as `linear.rs`'s `Timed` (without the timer).
struct Host(q::Controller, u64);

impl LinearController<{ q::NU }, { q::NX }, { q::NX }> for Host {
    fn step<R: LinearReference<{ q::NX }>>(
        &mut self,
        k: usize,
        x: &[f64; q::NX],
        r: &R,
    ) -> [f64; q::NU] {
        let xref = r.window::<q::Real, { q::N }>(k, f64::from(q::DT));
        let x: [q::Real; q::NX] = cast(x);
        let u = self.0.step(&x, &xref);
        self.1 += u64::from(self.0.status().fell_back());
        cast(&u)
    }
}

/// `linear.rs`'s loop on the host: the plant of the module's F and G (C = I) from rest, the reference
/// with state 2 at 1, no noise, seed 1.
fn host_run(cycles: usize) -> HostRun {
    let mut c = [[0.0; q::NX]; q::NX];
    for (i, row) in c.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut plant = LinearPlant::<{ q::NX }, { q::NU }, { q::NX }>::new(
        q::F.map(|row| cast(&row)),
        q::G.map(|row| cast(&row)),
        c,
        [0.0; q::NX],
    );
    let mut reference = [0.0; q::NX];
    reference[2] = 1.0;
    let scenario = LinearScenario {
        seed: 1,
        cycles,
        dt: f64::from(q::DT),
        noise: LinearNoiseConfig::NONE,
    };
    let mut host = Host(q::Controller::new(), 0);
    let mut commands = Vec::new();
    fly_linear(
        &mut plant,
        &mut host,
        &Setpoint(reference),
        &c,
        &scenario,
        |_| [0.0; q::NU],
        |s, _| commands.push(s.command.map(|u| u as f32)),
    );
    HostRun {
        commands,
        fallbacks: host.1,
        state: *plant.state(),
    }
}

/// The firmware's commands, from its `U k bits…` lines.
fn firmware_commands(uart: &str) -> Vec<[f32; q::NU]> {
    uart.lines()
        .filter_map(|l| l.strip_prefix("U "))
        .enumerate()
        .map(|(k, l)| {
            let mut f = l.split(' ');
            assert_eq!(f.next(), Some(k.to_string().as_str()), "{l}");
            let u: Vec<f32> = f
                .map(|h| f32::from_bits(u32::from_str_radix(h, 16).expect("hex bits")))
                .collect();
            u.try_into().expect("NU inputs a line")
        })
        .collect()
}

/// Units in the last place between two finite f32s of the same sign (or both near zero).
fn ulps(a: f32, b: f32) -> u32 {
    let key = |x: f32| {
        let b = x.to_bits() as i32;
        if b < 0 {
            i32::MIN - b
        } else {
            b
        }
    };
    key(a).abs_diff(key(b))
}

#[test]
fn quadcopter_flies_on_the_emulated_cortex_m4_and_agrees_with_the_host() {
    let f = m4_quadcopter_flight();
    assert_eq!(f.status, Some(0), "firmware exit status\n{}", f.uart);
    let r = &f.result;
    assert_eq!(r["ok"], Value::Bool(true), "{r}");
    assert_eq!(r["mode"], "linear");
    assert_eq!(r["board"], M4.name);
    let text = std::fs::read(root().join(QUADCOPTER_M4F)).expect("reading the spec");
    assert_eq!(r["spec_fnv1a64"], Value::String(fnv1a64(&text)));
    assert_eq!(r["scalar"], "f32");
    assert_eq!((uint(r, "nx"), uint(r, "nu")), (12, 4));
    assert_eq!(
        (uint(r, "horizon"), uint(r, "iterations")),
        (q::N as u64, q::ITERATIONS as u64)
    );
    assert_eq!(uint(r, "macs_per_cycle"), q::report::MACS_PER_CYCLE as u64);
    assert_eq!(uint(r, "cycles"), QUADCOPTER_CYCLES as u64);
    assert_eq!(uint(r, "unsolved_cycles"), 0);
    assert_calibrated(r, M4);

    // The same loop on the host: the same commands to the last bit of f32 rounding, the same
    // fallbacks, the same final state.
    let host = host_run(QUADCOPTER_CYCLES);
    let fw = firmware_commands(&f.uart);
    assert_eq!(fw.len(), host.commands.len());
    let mut identical = 0;
    for (k, (a, b)) in fw.iter().zip(&host.commands).enumerate() {
        for i in 0..q::NU {
            assert!(
                a[i].is_finite() && ulps(a[i], b[i]) <= 1,
                "cycle {k} input {i}: firmware {}, host {}",
                a[i],
                b[i]
            );
        }
        identical += usize::from(a.map(f32::to_bits) == b.map(f32::to_bits));
    }
    eprintln!(
        "quadcopter-m4f: {identical} of {} commands bit for bit the host's",
        fw.len()
    );
    assert_eq!(uint(r, "fallback_cycles"), host.fallbacks, "{r}");
    let micro: Vec<i64> = r["final_state_micro"]
        .as_array()
        .expect("final_state_micro")
        .iter()
        // serde_json reads the firmware's `-0` (a negative value that rounds to zero) as a float.
        .map(|v| v.as_f64().expect("a number") as i64)
        .collect();
    let host_micro: Vec<i64> = host
        .state
        .iter()
        .map(|x| (x * 1e6).round() as i64)
        .collect();
    eprintln!("final state, millionths: firmware {micro:?}, host {host_micro:?}");
    // The yaw step is under way (OSQP's loop: ψ towards 1 rad) and z stays near its start.
    assert!(
        host.state[2] > 0.5 && host.state[2] < 1.2,
        "{:?}",
        host.state
    );
    for (a, b) in micro.iter().zip(&host_micro) {
        assert!(
            a.abs_diff(*b) <= 1,
            "firmware {micro:?}, host {host_micro:?}"
        );
    }

    // Every cycle runs the same iterations; only the projections branch.
    assert_deterministic(r, TICK_SPREAD);
    // Instructions a cycle against `codegen::target`'s figure for ADMM on the M4F, which the compiler's
    // period check (`mpcc check`) prices the step with: the figure is this measurement rounded up, so a
    // regression of the emitted kernels, or a figure gone stale, fails here. And the step fits its
    // 100 ms period at 168 MHz at one instruction a cycle (the M4's best; flash wait states come on top).
    let instructions = uint(r, "ticks_mean") * M4.instructions_per_tick;
    let macs = uint(r, "macs_per_cycle");
    let period = (f64::from(q::DT) * 168e6) as u64;
    let per_mac = instructions as f64 / macs as f64;
    let figure = codegen::target::CORTEX_M4F.cycles_per_mac_admm_stages;
    eprintln!(
        "quadcopter-m4f: {instructions} instructions a cycle, {per_mac:.2} a multiply-add ({macs} multiply-adds; \
         the compiler's figure {figure}), {:.0} % of the {period} cycles of the period at one instruction a cycle",
        100.0 * instructions as f64 / period as f64
    );
    assert!(
        per_mac <= figure && per_mac >= 0.8 * figure,
        "{per_mac:.2} instructions a multiply-add against the compiler's {figure}"
    );
    assert!(
        instructions < period,
        "{instructions} instructions a cycle, more than the {period} cycles of the period"
    );
    let stack = uint(r, "cycle_stack_bytes");
    assert!(
        stack > 256 && stack < 16 * 1024 && stack < uint(r, "stack_bytes"),
        "control cycle stack {stack} B"
    );
    print_figures(f, M4);
}

#[test]
fn quadcopter_firmware_links_no_panicking_code() {
    let found = panicking_symbols(&m4_quadcopter_flight().elf);
    assert!(found.is_empty(), "links panicking code: {found:?}");
}

/// The same firmware on the emulated Zynq (`scripts/firmware.sh --cycles 100 SPEC`): the A9's VFP runs the
/// same f32 operations, so its commands are the M4F's and the host's to the bit.
#[test]
fn quadcopter_flies_on_the_emulated_zynq_with_the_same_commands() {
    static F: OnceLock<Flight> = OnceLock::new();
    let f = F.get_or_init(|| {
        build_and_fly(
            ZYNQ,
            Some(QUADCOPTER_M4F),
            "quadcopter-m4f",
            Some(QUADCOPTER_CYCLES),
        )
    });
    assert_eq!(f.status, Some(0), "firmware exit status\n{}", f.uart);
    let r = &f.result;
    assert_eq!(r["ok"], Value::Bool(true), "{r}");
    assert_eq!(r["board"], ZYNQ.name);
    assert_eq!(uint(r, "cycles"), QUADCOPTER_CYCLES as u64);
    let host = host_run(QUADCOPTER_CYCLES);
    let fw = firmware_commands(&f.uart);
    let bits = |c: &[[f32; q::NU]]| -> Vec<[u32; q::NU]> {
        c.iter().map(|u| u.map(f32::to_bits)).collect()
    };
    assert_eq!(bits(&fw), bits(&host.commands));
    assert_eq!(uint(r, "fallback_cycles"), host.fallbacks, "{r}");
    assert_eq!(
        r["commands_fnv1a64"],
        m4_quadcopter_flight().result["commands_fnv1a64"],
        "Cortex-A9 vs Cortex-M4F"
    );
    assert_deterministic(r, TICK_SPREAD);
    // The A9's figure for ADMM is these instructions a multiply-add, rounded up, at 1.5 cycles an
    // instruction (`codegen::target`).
    let instructions = uint(r, "ticks_mean") * ZYNQ.instructions_per_tick;
    let per_mac = instructions as f64 / uint(r, "macs_per_cycle") as f64;
    let figure = codegen::target::CORTEX_A9.cycles_per_mac_admm_stages / 1.5;
    assert!(
        per_mac <= figure && per_mac >= 0.8 * figure,
        "{per_mac:.2} instructions a multiply-add against the compiler's {figure:.2}"
    );
    let found = panicking_symbols(&f.elf);
    assert!(found.is_empty(), "links panicking code: {found:?}");
    print_figures(f, ZYNQ);
}
