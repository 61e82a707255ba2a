//! The envelope of the interior-point method's normal matrix (`codegen::structure::Envelope`): the
//! drone's independent axes become diagonal blocks, a coupled plant stays dense, and a dense Cholesky
//! factor of a matrix with that pattern has nothing outside the envelope (no fill, checked
//! independently of the emitted factorisation).
#![allow(non_snake_case)]

use codegen::ipm::{mpc_qp, normal_pattern};
use codegen::structure::Envelope;
use nalgebra::{DMatrix, DVector};

fn envelope_of(src: &str) -> (Envelope, DMatrix<bool>) {
    let spec = mpc_spec::load(src).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let qp = &p.qp;
    let n = qp.N * qp.u_min.len();
    let structure = mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()));
    let pattern = normal_pattern(&structure);
    (Envelope::of(&pattern), pattern)
}

/// A random symmetric positive definite matrix with `pattern`'s nonzeros (diagonally dominant).
fn spd_with(pattern: &DMatrix<bool>) -> DMatrix<f64> {
    let n = pattern.nrows();
    let mut seed = 7u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut M = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..i {
            if pattern[(i, j)] {
                let v = next();
                M[(i, j)] = v;
                M[(j, i)] = v;
            }
        }
    }
    for i in 0..n {
        M[(i, i)] = n as f64;
    }
    M
}

#[test]
fn paper_limits_splits_into_its_axes_and_fills_nothing_outside() {
    let (e, pattern) = envelope_of(include_str!("../../specs/paper-limits.toml"));
    let n = e.len();
    // 45 inputs and four slacks (vx, vy, vz, z): x, y and z blocks.
    assert_eq!(n, 49);
    let blocks = (0..n).filter(|&p| e.first[p] == p).count();
    assert_eq!(blocks, 3, "{:?}", e.first);
    let dense = n * (n + 1) / 2;
    println!(
        "paper-limits: envelope {} of {dense} entries, L·D·Lᵀ {} multiply-adds (dense n³/6 = {})",
        e.entries(),
        e.ldl_macs(),
        n * n * n / 6
    );
    assert!(e.entries() * 2 < dense);
    // Permute, factor densely, and look for fill outside the envelope.
    let M = spd_with(&pattern);
    let P = DMatrix::from_fn(n, n, |p, q| M[(e.order[p], e.order[q])]);
    let L = P.cholesky().unwrap().l();
    for p in 0..n {
        for q in 0..e.first[p] {
            assert_eq!(L[(p, q)], 0.0, "fill at ({p}, {q})");
        }
    }
    // A permuted position and its index agree.
    assert!((0..n).all(|i| e.order[e.position[i]] == i));
}

#[test]
fn the_quadcopter_is_one_dense_block() {
    let (e, _) = envelope_of(include_str!("../../specs/quadcopter.toml"));
    assert_eq!(e.order, (0..e.len()).collect::<Vec<_>>());
    assert!(e.first.iter().all(|f| *f == 0));
    let n = e.len();
    // Dense: the envelope count is the dense count, n³/6 to leading order.
    let dense = (n * n * n) as f64 / 6.0;
    assert!(
        (e.ldl_macs() as f64 - dense).abs() < 0.1 * dense,
        "{} vs {dense}",
        e.ldl_macs()
    );
}
