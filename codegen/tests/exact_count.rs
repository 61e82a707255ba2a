//! The exact cold-start count of the dual active-set method (`solver::active_set::exact`) against the
//! kernel itself, an independent check: the kernel run cold on a dense grid and on random parameters
//! never exceeds the exact count, the witness reproduces it, and on a small problem every region's
//! count is the kernel's at points inside it.
//!
//! `cargo test -p codegen --release --test exact_count -- --nocapture` prints the partitions.
#![allow(non_snake_case)]

use codegen::solver::active_set::exact::{exact_count, path_work, ExactCount, Limits};
use codegen::solver::active_set::{mpc::prepare, solve, Prepared};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One axis of the paper's double integrator with an input box and a soft speed limit, the state
/// over a box and the reference at 0: two parameters.
const SMALL: &str = include_str!("../../tests/specs/active-set/exact-small.toml");

fn setup(src: &str) -> (codegen::Problem, Prepared, ExactCount) {
    setup_with(src, true)
}

/// [`setup`], the parameters moving the sides in parallel combined into one coordinate or not.
fn setup_with(src: &str, combine: bool) -> (codegen::Problem, Prepared, ExactCount) {
    let spec = mpc_spec::load(src).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let region = codegen::sampling::resolve_region(&spec, &p, "test").unwrap();
    let prepared = prepare(&p.qp).unwrap();
    let count = exact_count(
        &p,
        &prepared,
        &region,
        Limits {
            lps: 2_000_000,
            dimension: 64,
            combine,
        },
    );
    (p, prepared, count)
}

/// The kernel's changes of the working set per block, cold, at θ.
fn kernel(
    p: &codegen::Problem,
    prepared: &Prepared,
    count: &ExactCount,
    theta: &[f64],
) -> Vec<usize> {
    let qp = count.parameters.qp(p, theta);
    let offsets = prepared.offsets(&qp).unwrap();
    solve(prepared, &offsets, None, 100_000).block_iterations
}

/// The kernel's work ([`codegen::solver::active_set::Macs::work`]), cold, at θ.
fn work(p: &codegen::Problem, prepared: &Prepared, count: &ExactCount, theta: &[f64]) -> usize {
    let qp = count.parameters.qp(p, theta);
    let offsets = prepared.offsets(&qp).unwrap();
    solve(prepared, &offsets, None, 100_000).macs.work()
}

fn report(name: &str, count: &ExactCount) {
    for (b, c) in count.blocks.iter().enumerate() {
        let hist = {
            let mut h = std::collections::BTreeMap::new();
            for q in &c.pieces {
                *h.entry(q.iterations).or_insert(0usize) += 1;
            }
            h
        };
        println!(
            "{name} block {b}: parameters {:?}, {} regions ({} infeasible), worst {} at {:?}, {} LPs ({} failed), {:.2} s, complete {}; regions by count {:?}",
            c.parameters.iter().map(|&j| &count.parameters.names[j]).collect::<Vec<_>>(),
            c.pieces.len(),
            c.infeasible,
            c.worst,
            c.witness,
            c.lps,
            c.lp_failures,
            c.seconds,
            c.complete,
            hist
        );
    }
}

#[test]
fn small_problem_regions_agree_with_the_kernel() {
    let (p, prepared, count) = setup(SMALL);
    report("small", &count);
    assert!(count.complete);
    let c = &count.blocks[0];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut mismatches = Vec::new();
    for q in &c.pieces {
        let mut points = vec![q.centre.clone()];
        for _ in 0..2 {
            let dir: Vec<f64> = q.centre.iter().map(|_| rng.gen_range(-1.0..1.0)).collect();
            let norm = dir.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-12);
            points.push(
                q.centre
                    .iter()
                    .zip(&dir)
                    .map(|(x, d)| x + 0.5 * q.radius * d / norm)
                    .collect(),
            );
        }
        for xi in points {
            let theta = count.parameters.theta(&c.coordinates, &xi);
            let k = kernel(&p, &prepared, &count, &theta)[0];
            if k != q.iterations {
                mismatches.push((q.iterations, k, xi, q.radius));
            }
        }
    }
    println!("mismatches: {mismatches:?}");
    assert!(mismatches.is_empty());
}

/// The kernel, cold, on a grid of `per_axis` points per parameter of each block (the others at the
/// centre) and on `draws` random θ over the whole box, never exceeds the exact count, per block and in
/// total; the witness reproduces every block's worst.
fn cross_check(name: &str, src: &str, per_axis: usize, draws: usize) -> ExactCount {
    let (p, prepared, count) = setup(src);
    report(name, &count);
    assert!(count.complete, "{name}: the partition did not complete");
    let at_witness = kernel(&p, &prepared, &count, &count.witness);
    // The heaviest path: its witness spends exactly its work, and no point below spends more.
    let paths = path_work(&p, &prepared, &count, mpc_spec::Scalar::F64).expect("the paths' work");
    assert_eq!(paths.mismatches, 0, "{name}: a centre solved off its path");
    assert_eq!(
        work(&p, &prepared, &count, &paths.witness),
        paths.cold_work,
        "{name}: the heaviest path's witness"
    );
    // The kernel's work at θ, at most the heaviest path's.
    let within_heaviest_path = |theta: &[f64]| {
        let w = work(&p, &prepared, &count, theta);
        assert!(
            w <= paths.cold_work,
            "{name}: work {w} > {} at {theta:?}",
            paths.cold_work
        );
        w
    };
    let mut heaviest = 0;
    for (b, c) in count.blocks.iter().enumerate() {
        assert_eq!(c.lp_failures, 0, "{name} block {b}");
        assert_eq!(at_witness[b], c.worst, "{name} block {b}: the witness");
        let dims = c.coordinates.len();
        let points = per_axis.pow(dims as u32);
        let mut seen = 0;
        for g in 0..points {
            let mut rest = g;
            let xi: Vec<f64> = (0..dims)
                .map(|_| {
                    let i = rest % per_axis;
                    rest /= per_axis;
                    -1.0 + 2.0 * i as f64 / (per_axis - 1) as f64
                })
                .collect();
            let theta = count.parameters.theta(&c.coordinates, &xi);
            let k = kernel(&p, &prepared, &count, &theta)[b];
            heaviest = heaviest.max(within_heaviest_path(&theta));
            seen = seen.max(k);
            assert!(
                k <= c.worst,
                "{name} block {b}: {k} > {} at {theta:?}",
                c.worst
            );
        }
        println!(
            "{name} block {b}: grid of {points}, most {seen} (exact {})",
            c.worst
        );
    }
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let par = &count.parameters;
    let mut seen = 0;
    for _ in 0..draws {
        let theta: Vec<f64> = (0..par.len())
            .map(|j| rng.gen_range(par.lo[j]..=par.hi[j]))
            .collect();
        let k = kernel(&p, &prepared, &count, &theta);
        for (b, c) in count.blocks.iter().enumerate() {
            assert!(
                k[b] <= c.worst,
                "{name} block {b}: {} > {} at {theta:?}",
                k[b],
                c.worst
            );
        }
        let total: usize = k.iter().sum();
        seen = seen.max(total);
        assert!(total <= count.worst);
        heaviest = heaviest.max(within_heaviest_path(&theta));
    }
    println!("{name}: {draws} draws, most {seen} (exact {})", count.worst);
    println!(
        "{name}: the grid's and draws' heaviest work {heaviest} (the heaviest path {})",
        paths.cold_work
    );
    count
}

#[test]
fn small_problem_grid_and_draws_stay_within_the_count() {
    cross_check("small", SMALL, 41, 2000);
}

/// With the position's reference over [−1, 1] and the speed's over [−0.5, 0.5] the block depends on four
/// parameters, but x₀'s position and its reference enter its sides only through their difference (no
/// row bounds the position): the partition is over three coordinates, and the kernel run on a grid and
/// on draws over the whole four-dimensional box (not along the coordinates) stays within its count.
#[test]
fn a_position_and_its_reference_are_partitioned_as_their_difference() {
    let src = SMALL
        .replace("reference_min = [0, 0]", "reference_min = [-1, -0.5]")
        .replace("reference_max = [0, 0]", "reference_max = [1, 0.5]");
    let count = cross_check("small with a reference", &src, 11, 2000);
    let c = &count.blocks[0];
    let names = &count.parameters.names;
    assert_eq!(c.parameters.len(), 4);
    let coordinates: Vec<String> = c.coordinates.iter().map(|k| k.name(names)).collect();
    assert_eq!(coordinates, ["x0[0] - r[0]", "x0[1]", "r[1]"]);
    // The partition over the four parameters apart is the same one lifted: the same count and the same
    // number of regions for each count.
    let (_, _, apart) = setup_with(&src, false);
    let a = &apart.blocks[0];
    assert!(a.complete);
    assert_eq!(a.coordinates.len(), 4);
    let by_count = |c: &codegen::solver::active_set::exact::BlockCount| {
        let mut h = std::collections::BTreeMap::new();
        for q in &c.pieces {
            *h.entry((q.iterations, format!("{:?}", q.end)))
                .or_insert(0usize) += 1;
        }
        h
    };
    assert_eq!(a.worst, c.worst);
    assert_eq!(by_count(a), by_count(c));
    println!("apart: {} LPs, combined: {} LPs", a.lps, c.lps);
}

/// `[mpc.region] exact_lps` sets the build's budget of LPs per block: SMALL with both references needs
/// 20,873, above the default 20,000, so by default the count is the sample's and the note says where the
/// budget ran out; with `exact_lps = 100_000` the build carries the complete partition's count.
#[test]
fn exact_lps_lets_the_build_finish_a_larger_partition() {
    let src = SMALL
        .replace("reference_min = [0, 0]", "reference_min = [-1, -0.5]")
        .replace("reference_max = [0, 0]", "reference_max = [1, 0.5]");
    let exact_of = |src: &str| {
        let p = codegen::lower(&mpc_spec::load(src).unwrap()).unwrap();
        p.qp.evidence
            .and_then(|e| e.exact)
            .expect("the exact count")
    };
    let default = exact_of(&src);
    assert!(!default.complete);
    let note = default.note.expect("why it fell back");
    assert!(
        note.contains("ran out of the build's 20000 feasibility LPs") && note.contains("exact_lps"),
        "{note}"
    );
    let raised = exact_of(&src.replace("[mpc.region]\n", "[mpc.region]\nexact_lps = 100_000\n"));
    assert!(raised.complete, "{:?}", raised.note);
    let (_, _, count) = setup(&src);
    assert_eq!(raised.cold_worst, count.worst);
    assert_eq!(raised.regions, count.regions);
    assert!(
        raised.lps > 20_000 && raised.lps <= 100_000,
        "{}",
        raised.lps
    );
}

/// Not timed yet within the session that wrote it: run with `--release -- --ignored`.
#[test]
#[ignore]
fn paper_limits_per_axis() {
    cross_check(
        "paper-limits",
        include_str!("../../tests/specs/active-set/paper-limits.toml"),
        7,
        300,
    );
}

/// Paper-limits' third block (the height, its floor soft) has a sliver near a corner of the region
/// where the exact iteration returns to a working set it scanned (a degenerate tie): the region ends
/// there as cycling, outside the count, and the partition goes on (it used to run that path to
/// `MAX_DEPTH` and stop). The kernel, whose tolerances break the tie, solves the sliver's centre.
#[test]
fn a_cycle_in_exact_arithmetic_ends_its_region_and_the_partition_goes_on() {
    use codegen::solver::active_set::exact::End;
    let spec = mpc_spec::load(include_str!(
        "../../tests/specs/active-set/paper-limits.toml"
    ))
    .unwrap();
    let p = codegen::lower(&spec).unwrap();
    let region = codegen::sampling::resolve_region(&spec, &p, "test").unwrap();
    let prepared = prepare(&p.qp).unwrap();
    let limits = Limits {
        lps: 8_000,
        dimension: 64,
        combine: true,
    };
    let count = exact_count(&p, &prepared, &region, limits);
    let c = &count.blocks[2];
    report("paper-limits", &count);
    assert!(c.cycling >= 1, "no cycling region found");
    assert!(c.cycling_radius < 1e-5, "{}", c.cycling_radius);
    assert!(
        c.pieces.len() > c.cycling + 100,
        "{} regions",
        c.pieces.len()
    );
    for q in c.pieces.iter().filter(|q| q.end == End::Cycles) {
        assert!(
            q.iterations <= c.worst + 8,
            "{} against {}",
            q.iterations,
            c.worst
        );
        let theta = count.parameters.theta(&c.coordinates, &q.centre);
        let k = kernel(&p, &prepared, &count, &theta);
        assert!(k[2] < 100, "the kernel at the sliver's centre: {k:?}");
    }
}

/// The build carries the exact count (`[mpc.region] certificate = "exact"`, the default): the
/// certificate's count is the partition's, the cold cap is at least it, and a warm solve that runs out
/// restarts cold within that cap and ends at the optimum, in `warm + cold` changes at most.
#[test]
fn the_build_carries_the_exact_count_and_a_warm_solve_restarts_cold() {
    use codegen::solver::active_set::mpc::{control_step, Caps};
    use codegen::solver::active_set::Status;
    let (p, prepared, count) = setup(SMALL);
    let exact =
        p.qp.evidence
            .as_ref()
            .and_then(|e| e.exact.clone())
            .expect("the exact count in the certificate");
    assert!(exact.complete, "{:?}", exact.note);
    assert_eq!(exact.cold_worst, count.worst);
    // No sampled cold case exceeds it (the build checks this too, and distrusts the partition if one does).
    let sampled = p.qp.evidence.as_ref().unwrap().cold_worst;
    assert!(
        sampled <= exact.cold_worst,
        "{sampled} > {}",
        exact.cold_worst
    );
    assert_eq!(exact.regions, count.regions);
    // The heaviest path's work is carried, no sampled cold case spent more, and the cold solve's
    // budget is it plus its margin.
    let paths = path_work(&p, &prepared, &count, mpc_spec::Scalar::F64).unwrap();
    assert_eq!(exact.cold_work, Some(paths.cold_work));
    assert_eq!(exact.path_mismatches, 0);
    let e = p.qp.evidence.as_ref().unwrap();
    assert!(
        e.cold_work_worst <= paths.cold_work,
        "a sampled cold case spent {} > {}",
        e.cold_work_worst,
        paths.cold_work
    );
    let caps = Caps::of(&p.qp);
    assert_eq!(
        caps.cold_work,
        paths.cold_work + codegen::sampling::margin(paths.cold_work)
    );
    assert_eq!(caps.cold, p.qp.iterations.max(count.worst));
    // The warm cap is the sample's warm-started need plus its margin, at most the count.
    let e = p.qp.evidence.as_ref().unwrap();
    let warm = e.warm_started_worst + codegen::sampling::margin(e.warm_started_worst);
    assert_eq!(caps.warm, warm.min(p.qp.iterations));
    let spec = mpc_spec::load(SMALL).unwrap();
    let plan = codegen::plan(&spec, &p).unwrap();
    let c = codegen::certify(&p, &plan);
    assert_eq!(c.cold_iterations, Some(caps.cold));
    assert_eq!(c.exact.as_ref(), Some(&exact));

    // "sampled": no partition, and the cold cap is the sample's.
    let sampled = SMALL.replace(
        "[mpc.region]\n",
        "[mpc.region]\ncertificate = \"sampled\"\n",
    );
    let q = codegen::lower(&mpc_spec::load(&sampled).unwrap()).unwrap();
    assert!(q.qp.evidence.as_ref().unwrap().exact.is_none());
    assert_eq!(Caps::of(&q.qp).cold, q.qp.iterations);

    // A warm start from the optimum at one corner of the region, solved at the opposite one with one
    // change allowed: the warm solve runs out, the cold restart ends at the optimum.
    let par = &count.parameters;
    let at = |theta: &[f64]| {
        let qp = par.qp(&p, theta);
        let offsets = prepared.offsets(&qp).unwrap();
        (qp, offsets)
    };
    let (_, far) = at(&par.hi);
    let start = codegen::solver::active_set::solve(&prepared, &far, None, 100_000).working_set;
    let (f, offset) = par.data(&p, &par.lo);
    let plan = nalgebra::DVector::zeros(f.len());
    let tight = Caps::with(1, count.worst);
    let step = control_step(
        &p.qp,
        &prepared,
        &f,
        &offset,
        Some(&start),
        &plan,
        tight,
        false,
        mpc_spec::Scalar::F64,
    );
    let cold = control_step(
        &p.qp,
        &prepared,
        &f,
        &offset,
        None,
        &plan,
        tight,
        false,
        mpc_spec::Scalar::F64,
    );
    assert_eq!(step.outcome.status, Status::Solved);
    assert!(
        step.outcome.iterations > cold.outcome.iterations,
        "the warm solve ran out first"
    );
    assert!(step.outcome.iterations <= tight.per_step());
    assert_eq!(step.plan, cold.plan);
}
