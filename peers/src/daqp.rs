//! DAQP 0.11.0 through `c/peer_daqp.c`: its workspace set up once on a problem, then one solve per
//! step from the state, the reference window and the last input.

use crate::Data;
use core::ffi::c_void;

/// DAQP's `c_float`: `f32` when it is built with `DAQP_SINGLE_PRECISION` (build.rs), else `f64`.
#[cfg(daqp_single)]
pub type CFloat = f32;
/// DAQP's `c_float`: `f32` when it is built with `DAQP_SINGLE_PRECISION` (build.rs), else `f64`.
#[cfg(not(daqp_single))]
pub type CFloat = f64;

/// The longest vector passed per solve (state, window, input, plan).
pub const MAX: usize = 256;

extern "C" {
    fn peer_daqp_setup(
        nx: i32,
        nu: i32,
        nr: i32,
        np: i32,
        n: i32,
        rows: i32,
        h: *const CFloat,
        a: *const CFloat,
        z_min: *const CFloat,
        z_max: *const CFloat,
        lower: *const CFloat,
        upper: *const CFloat,
        wx: *const CFloat,
        wu: *const CFloat,
        fx: *const CFloat,
        fr: *const CFloat,
        fu: *const CFloat,
        w: *const CFloat,
        flag: *mut i32,
    ) -> *mut c_void;
    fn peer_daqp_form(p: *mut c_void, x0: *const CFloat, r: *const CFloat, u_last: *const CFloat);
    fn peer_daqp_solve(p: *mut c_void, z: *mut CFloat, iter: *mut i32) -> i32;
}

/// The first `N` entries of `x` as DAQP's scalar (the rest zero).
pub fn convert<const N: usize>(x: &[f64]) -> [CFloat; N] {
    let mut out = [0.0; N];
    for (o, &v) in out.iter_mut().zip(x) {
        *o = v as CFloat;
    }
    out
}

/// A DAQP workspace on one problem.
pub struct Daqp {
    work: *mut c_void,
    n: usize,
    z: [CFloat; MAX],
    iterations: u32,
}

impl Daqp {
    /// Sets DAQP up on `data` (which it keeps pointers to). `None` if memory ran out or DAQP refused
    /// the problem.
    pub fn new(data: &Data) -> Option<Self> {
        if data.n > MAX || data.nx > MAX || data.nr > MAX || data.nu > MAX {
            return None;
        }
        let mut flag = 0;
        // SAFETY: every pointer is to a slice of the length the C side reads (Data's documented
        // shapes), 'static, so alive as long as the workspace that keeps pointers to its copies.
        let work = unsafe {
            peer_daqp_setup(
                data.nx as i32,
                data.nu as i32,
                data.nr as i32,
                data.np as i32,
                data.n as i32,
                data.m as i32,
                data.h.as_ptr(),
                data.a.as_ptr(),
                data.z_min.as_ptr(),
                data.z_max.as_ptr(),
                data.lower.as_ptr(),
                data.upper.as_ptr(),
                data.wx.as_ptr(),
                data.wu.as_ptr(),
                data.fx.as_ptr(),
                data.fr.as_ptr(),
                data.fu.as_ptr(),
                data.w.as_ptr(),
                &mut flag,
            )
        };
        (!work.is_null() && flag >= 0).then_some(Daqp {
            work,
            n: data.n,
            z: [0.0; MAX],
            iterations: 0,
        })
    }

    /// Forms f and the rows' bounds of one step. The arrays hold at least nx, nr and nu entries.
    pub fn form(&mut self, x0: &[CFloat; MAX], r: &[CFloat; MAX], u_last: &[CFloat; MAX]) {
        // SAFETY: `work` is a live workspace from peer_daqp_setup; the inputs hold MAX ≥ nx, nr, nu
        // entries (checked in `new`).
        unsafe { peer_daqp_form(self.work, x0.as_ptr(), r.as_ptr(), u_last.as_ptr()) }
    }

    /// Solves the formed step from the previous working set: DAQP's exit flag (1 optimal; ≤ 0
    /// failed).
    pub fn solve(&mut self) -> i32 {
        let mut iter = 0;
        // SAFETY: `work` is a live workspace; z holds MAX ≥ n entries (checked in `new`).
        let flag = unsafe { peer_daqp_solve(self.work, self.z.as_mut_ptr(), &mut iter) };
        self.iterations = iter.max(0) as u32;
        flag
    }

    /// The last solution z (n).
    pub fn z(&self) -> &[CFloat] {
        &self.z[..self.n]
    }

    /// Active-set iterations of the last solve.
    pub fn iterations(&self) -> u32 {
        self.iterations
    }
}
