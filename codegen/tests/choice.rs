//! `method = "auto"`, the default (`codegen::choice`): the candidates weighed, the choice for every
//! shipped spec pinned, FGM-only keys choosing FGM, and no choice that misses `accuracy` on its sample.
#![allow(non_snake_case)]

use codegen::{generate_from_source, lower, Opt};
use mpc_spec::{load, Method};

/// `src` with its `method = …` line removed: the default, `auto`.
fn without_method(src: &str) -> String {
    src.lines()
        .filter(|l| !l.trim_start().starts_with("method ="))
        .collect::<Vec<_>>()
        .join("\n")
}

const PAPER: &str = include_str!("../../specs/paper.toml");

#[test]
fn the_paper_without_its_method_line_is_fgm_and_emits_the_same_module() {
    let auto = without_method(PAPER);
    assert!(!auto.contains("method ="));
    let spec = load(&auto).unwrap();
    assert_eq!(spec.mpc.method, Method::Auto);
    let a = generate_from_source(&auto, &Opt::default()).unwrap();
    let written = generate_from_source(PAPER, &Opt::default()).unwrap();
    assert_eq!(a.problem.qp.method, Method::Fgm);
    assert_eq!(a.problem.requested, Method::Auto);
    assert_eq!(a.tokens.to_string(), written.tokens.to_string());
    // FGM and the interior-point method were weighed (the latter has no region to be certified on);
    // ADMM, last, is not weighed once an earlier candidate can be used.
    let c = &a.certificate.candidates;
    assert_eq!(c.len(), 4);
    assert!(c[0].chosen && c[0].method == Method::Fgm && c[0].certified == "as written");
    for k in &c[1..3] {
        assert!(
            k.unavailable.as_deref().unwrap().contains("no range"),
            "{c:?}"
        );
    }
    assert_eq!(c[2].method, Method::ActiveSet);
    assert!(
        c[3].method == Method::Admm && c[3].unavailable.as_deref().unwrap().contains("not weighed"),
        "{c:?}"
    );
    assert!(written.certificate.candidates.is_empty());
}

#[test]
fn fgm_only_keys_choose_fgm() {
    let stepped = without_method(PAPER).replace("step = \"auto\"", "step = 0.04");
    let spec = load(&stepped).unwrap();
    assert_eq!(
        (spec.mpc.method, spec.mpc.method_requested),
        (Method::Fgm, Method::Auto)
    );
    let tolerance =
        without_method(PAPER).replace("iterations = 30", "iterations = \"auto\"\ntolerance = 1e-4");
    assert_eq!(load(&tolerance).unwrap().mpc.method, Method::Fgm);
    // With a constraint as well, `auto` does not follow `step` into a method that cannot take the
    // constraint: the one error is on `step`, and its hint names the constrained methods' key.
    let constrained = stepped.replace(
        "u_max = [10, 10, 10]",
        "u_max = [10, 10, 10]\nx_max = [inf, inf, inf, 2, 2, 2]",
    );
    let err = load(&constrained).unwrap_err();
    assert_eq!(err.iter().count(), 1, "{err:?}");
    let d = err.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("`step` is a setting of the first-order methods"),
        "{}",
        d.message
    );
    let note = d.note.as_deref().unwrap();
    assert!(
        note.contains("weighs `ipm` and `admm`") && note.contains("remove `step`"),
        "{note}"
    );
}

/// The choice of every shipped spec with its method line removed, pinned.
#[test]
fn shipped_specs_under_auto() {
    let specs: &[(&str, &str, Method)] = &[
        ("paper", include_str!("../../specs/paper.toml"), Method::Fgm),
        (
            "paper-faithful",
            include_str!("../../specs/paper-faithful.toml"),
            Method::Gradient,
        ),
        (
            "paper-initial",
            include_str!("../../specs/paper-initial.toml"),
            Method::Gradient,
        ),
        (
            "paper-offset-free",
            include_str!("../../specs/paper-offset-free.toml"),
            Method::Fgm,
        ),
        (
            "afti16",
            include_str!("../../specs/afti16.toml"),
            Method::ActiveSet,
        ),
        (
            "quadcopter",
            include_str!("../../specs/quadcopter.toml"),
            Method::ActiveSet,
        ),
        (
            "hover",
            include_str!("../../specs/hover.toml"),
            Method::ActiveSet,
        ),
        (
            "paper-limits",
            include_str!("../../specs/paper-limits.toml"),
            Method::Ipm,
        ),
        (
            "paper-geofence",
            include_str!("../../specs/paper-geofence.toml"),
            Method::ActiveSet,
        ),
    ];
    for (name, src, expected) in specs {
        let written = load(src).unwrap().mpc.method;
        let auto = without_method(src);
        let spec = load(&auto).unwrap();
        let p = lower(&spec).unwrap();
        // `gradient` is never auto's choice: FGM dominates it; the paper's faithful specs keep their
        // written method, and under auto their FGM-only `step` chooses FGM.
        let chosen = p.qp.method;
        println!("{name}: written {written:?}, auto {chosen:?}");
        let expected = if *expected == Method::Gradient {
            Method::Fgm
        } else {
            *expected
        };
        assert_eq!(chosen, expected, "{name}");
        // FGM-only keys (paper-faithful's and paper-initial's numeric `step`) choose FGM unweighed.
        if p.candidates.is_empty() {
            assert!(auto.contains("step = 0"), "{name}: no candidates weighed");
            continue;
        }
        // Where auto now chooses the dual active-set method, the previous release's choice (without it)
        // was the interior-point method, which these specs wrote until they left the choice to auto:
        // `mpcc check` names it.
        if chosen == Method::ActiveSet {
            assert_eq!(
                written,
                Method::Auto,
                "{name}: a shipped spec that auto serves writes no method"
            );
            assert_eq!(
                codegen::choice::previous_choice(&p.candidates),
                Some(Method::Ipm),
                "{name}"
            );
        }
        // ADMM is listed, not weighed: the interior-point method (or FGM) reaches `accuracy` first.
        let admm = p.candidates.iter().find(|k| k.method == Method::Admm);
        assert!(
            admm.is_some_and(|k| k
                .unavailable
                .as_deref()
                .is_some_and(|w| w.contains("not weighed"))),
            "{name}: {admm:?}"
        );
    }
}

/// A box-only, ill-conditioned plant (OSQP's quadcopter without its state bounds) with a region: both
/// methods are sampled, and a written count that FGM cannot meet leaves only the interior-point method.
#[test]
fn a_candidate_that_misses_accuracy_at_a_written_count_is_never_chosen() {
    let box_only: String = include_str!("../../specs/quadcopter.toml")
        .lines()
        // The state bounds of `[mpc]` (those of `[mpc.region]` stay).
        .filter(|l| {
            !l.starts_with("x_min = [-0.52")
                && !l.starts_with("x_max = [0.52")
                && !l.starts_with("method =")
        })
        .collect::<Vec<_>>()
        .join("\n");
    let fixed = box_only.replace("iterations = \"auto\"", "iterations = 30");
    assert!(fixed.contains("iterations = 30"), "the spec writes `auto`");
    let g = generate_from_source(&fixed, &Opt::default()).unwrap();
    let c = &g.certificate.candidates;
    let fgm = c.iter().find(|k| k.method == Method::Fgm).unwrap();
    let ipm = c.iter().find(|k| k.method == Method::Ipm).unwrap();
    assert_eq!(fgm.reaches_accuracy, Some(false), "{fgm:?}");
    assert_eq!(ipm.reaches_accuracy, Some(true), "{ipm:?}");
    assert!(ipm.chosen && !fgm.chosen);
    assert!(
        fgm.macs_per_solve < ipm.macs_per_solve,
        "FGM is cheaper but misses"
    );
    assert_eq!(g.problem.qp.method, Method::Ipm);
}

/// With a region, FGM on the well-conditioned paper is sampled too and is far cheaper than the
/// interior-point method.
#[test]
fn the_cheapest_candidate_that_reaches_accuracy_wins() {
    let src = without_method(PAPER)
        .replace("iterations = 30", "iterations = \"auto\"")
        .replace(
            "[kalman]",
            "[mpc.region]\nx_min = [-7.0, -5.0, 0.0, -4.0, -4.0, -4.0]\nx_max = [11.0, 11.0, 16.0, 4.0, 4.0, 4.0]\n\n[kalman]",
        );
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    let c = &g.certificate.candidates;
    assert!(
        c.iter()
            .filter(|k| k.method != Method::Admm)
            .all(|k| k.unavailable.is_none() && k.reaches_accuracy == Some(true)),
        "{c:?}"
    );
    let (fgm, ipm) = (&c[0], &c[1]);
    assert!(
        fgm.chosen && fgm.macs_per_solve * 3 < ipm.macs_per_solve,
        "{c:?}"
    );
}

/// The interior-point method's form of its normal system for every shipped constrained spec (with
/// `method = "ipm"` written where `auto` picks the dual active set), pinned: the Riccati form where it is available for the problem and counts fewer multiply-adds per
/// iteration (hover: a box on every state, sparse dynamics), the condensed form otherwise. The
/// quadcopter's Riccati form is available but dearer (three rows a stage), as are paper-limits' and
/// paper-geofence's (soft rows: the slacks' Schur complement; and the condensed form splits into the
/// axes); afti16 weights its moves (`r_du`), for which the Riccati form is not built.
#[test]
fn shipped_specs_normal_system_form() {
    use codegen::riccati::{Choice, Form};
    // (name, spec, form, Riccati form available, Riccati form counted)
    let specs: &[(&str, &str, Form, bool, bool)] = &[
        (
            "hover",
            include_str!("../../specs/hover.toml"),
            Form::Riccati,
            true,
            true,
        ),
        (
            "quadcopter",
            include_str!("../../specs/quadcopter.toml"),
            Form::Condensed,
            true,
            true,
        ),
        (
            "afti16",
            include_str!("../../specs/afti16.toml"),
            Form::Condensed,
            false,
            false,
        ),
        (
            "paper-limits",
            include_str!("../../specs/paper-limits.toml"),
            Form::Condensed,
            true,
            true,
        ),
        (
            "paper-geofence",
            include_str!("../../specs/paper-geofence.toml"),
            Form::Condensed,
            true,
            true,
        ),
    ];
    for (name, src, form, available, counted) in specs {
        let src = &if src.contains("\nmethod = ") {
            src.to_string()
        } else {
            src.replacen("\n[mpc]\n", "\n[mpc]\nmethod = \"ipm\"\n", 1)
        };
        // One build (the certificate is sampled once): its problem, and what `mpcc check --json` carries.
        let g = codegen::generate_from_source(src, &Opt::default()).unwrap();
        let p = &g.problem;
        assert_eq!(p.qp.method, Method::Ipm, "{name}");
        let c = Choice::of(&p.qp);
        println!("{name}: {c:?}");
        assert_eq!(c.form, *form, "{name}: {c:?}");
        assert_eq!(c.riccati_unavailable.is_none(), *available, "{name}: {c:?}");
        assert_eq!(
            c.riccati_macs_per_iteration.is_some(),
            *counted,
            "{name}: {c:?}"
        );
        // The chosen form is the cheaper of those available, and it is what the cost model counts.
        let riccati = c.riccati_macs_per_iteration.unwrap_or(usize::MAX);
        assert_eq!(
            c.form == Form::Riccati,
            *available && riccati < c.condensed_macs_per_iteration,
            "{name}: {c:?}"
        );
        assert_eq!(
            codegen::ipm::mpc_macs_per_iteration(&p.qp),
            c.macs_per_iteration(),
            "{name}"
        );
        // `mpcc check --json` carries it.
        assert_eq!(g.certificate.normal_form.as_ref(), Some(&c), "{name}");
    }
}
