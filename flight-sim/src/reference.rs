//! Reference trajectories: the paper-like flight and the step scenario.

use core::f64::consts::PI;

use crate::model::{DT, NX};
use crate::real::{cast, Real};

/// A reference state `[px, py, pz, vx, vy, vz]` for every time.
pub trait Reference {
    /// The reference state at time `t` (s).
    fn state_at(&self, t: f64) -> [f64; NX];

    /// The reference state at cycle `k`, time `k·DT`.
    fn state(&self, k: usize) -> [f64; NX] {
        self.state_at(k as f64 * DT)
    }

    /// The N-step window an MPC needs at cycle `k`: `window[j]` is the reference for the
    /// predicted state `j + 1`, i.e. the reference at cycle `k + 1 + j`, in the controller's
    /// scalar `T`.
    fn window<T: Real, const N: usize>(&self, k: usize) -> [[T; NX]; N] {
        let mut w = [[T::default(); NX]; N];
        for (j, row) in w.iter_mut().enumerate() {
            *row = cast(&self.state(k + 1 + j));
        }
        w
    }
}

impl<R: Reference + ?Sized> Reference for &R {
    fn state_at(&self, t: f64) -> [f64; NX] {
        (**self).state_at(t)
    }
}

/// Hold one position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hover(pub [f64; 3]);

impl Reference for Hover {
    fn state_at(&self, _t: f64) -> [f64; NX] {
        let p = self.0;
        [p[0], p[1], p[2], 0.0, 0.0, 0.0]
    }
}

/// The step scenario of Table 3: hover at `origin`, and at time `at` the position reference
/// jumps by `size` (velocity reference zero throughout).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Hover position before the step, m.
    pub origin: [f64; 3],
    /// Step on each axis, m.
    pub size: [f64; 3],
    /// Time of the step, s.
    pub at: f64,
}

impl Step {
    /// A 1 m step on each axis from hover at `[0, 0, 10]`, at t = 1 s.
    pub const fn paper() -> Self {
        Self {
            origin: [0.0, 0.0, 10.0],
            size: [1.0, 1.0, 1.0],
            at: 1.0,
        }
    }
}

impl Reference for Step {
    fn state_at(&self, t: f64) -> [f64; NX] {
        let mut x = [0.0; NX];
        for i in 0..3 {
            x[i] = self.origin[i] + if t >= self.at { self.size[i] } else { 0.0 };
        }
        x
    }
}

/// One piece of a [`Trajectory`], starting where the previous one ended.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    /// Stay put.
    Hold,
    /// Rest to rest by `delta` along a quintic (smooth velocity and acceleration).
    Smooth { delta: [f64; 3] },
    /// Constant velocity `delta / duration`: the velocity jumps at both ends (a sharp corner).
    Line { delta: [f64; 3] },
    /// `turns` turns of a circle of `radius` (counter-clockwise) from the phase `phase0`,
    /// climbing `climb` metres on the way: a circle when `climb` is 0, a helix otherwise.
    Circle {
        radius: f64,
        phase0: f64,
        turns: f64,
        climb: f64,
    },
    /// A figure eight (lemniscate of Gerono) of half-width `amplitude` in the horizontal plane:
    /// `x = A sin(ωτ)`, `y = (A/2) sin(2ωτ)`, one period.
    Eight { amplitude: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Segment {
    start: f64,
    duration: f64,
    p0: [f64; 3],
    shape: Shape,
}

impl Segment {
    /// Position and velocity at `tau` seconds into the segment.
    fn eval(&self, tau: f64) -> [f64; NX] {
        let p0 = self.p0;
        let t = self.duration;
        let mut x = [p0[0], p0[1], p0[2], 0.0, 0.0, 0.0];
        match self.shape {
            Shape::Hold => {}
            Shape::Smooth { delta } => {
                let s = tau / t;
                let pos = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
                let vel = 30.0 * s * s * (1.0 - s) * (1.0 - s) / t;
                for i in 0..3 {
                    x[i] += delta[i] * pos;
                    x[i + 3] = delta[i] * vel;
                }
            }
            Shape::Line { delta } => {
                for i in 0..3 {
                    x[i] += delta[i] * tau / t;
                    x[i + 3] = delta[i] / t;
                }
            }
            Shape::Circle {
                radius,
                phase0,
                turns,
                climb,
            } => {
                let w = 2.0 * PI * turns / t;
                let phi = phase0 + w * tau;
                let (s0, c0) = libm::sincos(phase0);
                let (s, c) = libm::sincos(phi);
                x[0] += radius * (c - c0);
                x[1] += radius * (s - s0);
                x[2] += climb * tau / t;
                x[3] = -radius * w * s;
                x[4] = radius * w * c;
                x[5] = climb / t;
            }
            Shape::Eight { amplitude } => {
                let w = 2.0 * PI / t;
                let (s1, c1) = libm::sincos(w * tau);
                let (s2, c2) = libm::sincos(2.0 * w * tau);
                x[0] += amplitude * s1;
                x[1] += 0.5 * amplitude * s2;
                x[3] = amplitude * w * c1;
                x[4] = amplitude * w * c2;
            }
        }
        x
    }
}

const SEGMENTS: usize = 17;

/// The reference flight: about 111 s of take-off and climb, a square with sharp corners, a
/// climbing diagonal and its sharp reversal, a circle, a figure eight, a climbing helix and a
/// descent, with hovers between the patterns. Positions are continuous everywhere; velocities
/// jump at the corners. After the end the reference holds the last position.
///
/// | t (s) | pattern |
/// |---|---|
/// | 0-2 | hover on the ground at the origin |
/// | 2-10 | take-off and climb to 10 m (smooth) |
/// | 12-28 | square, 10 m legs at 2.5 m/s (+x, +y, -x, -y) |
/// | 28-36 | diagonal climb of (5, 5, 2) m in 4 s and straight back |
/// | 38-53 | circle of radius 5 m (2.1 m/s) |
/// | 55-75 | figure eight, 12 m × 6 m, in 20 s |
/// | 77-103 | helix, radius 4 m, two turns, climbing 6 m |
/// | 103-109 | descent of 10 m (smooth) |
/// | 109-111 | hover |
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trajectory {
    segments: [Segment; SEGMENTS],
}

impl Trajectory {
    /// The flight described on [`Trajectory`].
    pub fn paper() -> Self {
        let shapes: [(f64, Shape); SEGMENTS] = [
            (2.0, Shape::Hold),
            (
                8.0,
                Shape::Smooth {
                    delta: [0.0, 0.0, 10.0],
                },
            ),
            (2.0, Shape::Hold),
            (
                4.0,
                Shape::Line {
                    delta: [10.0, 0.0, 0.0],
                },
            ),
            (
                4.0,
                Shape::Line {
                    delta: [0.0, 10.0, 0.0],
                },
            ),
            (
                4.0,
                Shape::Line {
                    delta: [-10.0, 0.0, 0.0],
                },
            ),
            (
                4.0,
                Shape::Line {
                    delta: [0.0, -10.0, 0.0],
                },
            ),
            (
                4.0,
                Shape::Line {
                    delta: [5.0, 5.0, 2.0],
                },
            ),
            (
                4.0,
                Shape::Line {
                    delta: [-5.0, -5.0, -2.0],
                },
            ),
            (2.0, Shape::Hold),
            (
                15.0,
                Shape::Circle {
                    radius: 5.0,
                    phase0: -PI / 2.0,
                    turns: 1.0,
                    climb: 0.0,
                },
            ),
            (2.0, Shape::Hold),
            (20.0, Shape::Eight { amplitude: 6.0 }),
            (2.0, Shape::Hold),
            (
                26.0,
                Shape::Circle {
                    radius: 4.0,
                    phase0: PI,
                    turns: 2.0,
                    climb: 6.0,
                },
            ),
            (
                6.0,
                Shape::Smooth {
                    delta: [0.0, 0.0, -10.0],
                },
            ),
            (2.0, Shape::Hold),
        ];
        let empty = Segment {
            start: 0.0,
            duration: 0.0,
            p0: [0.0; 3],
            shape: Shape::Hold,
        };
        let mut segments = [empty; SEGMENTS];
        let mut start = 0.0;
        let mut p0 = [0.0; 3];
        for (seg, &(duration, shape)) in segments.iter_mut().zip(&shapes) {
            *seg = Segment {
                start,
                duration,
                p0,
                shape,
            };
            let end = seg.eval(duration);
            p0 = [end[0], end[1], end[2]];
            start += duration;
        }
        Self { segments }
    }

    /// Length of the flight, s.
    pub fn duration(&self) -> f64 {
        let last = &self.segments[SEGMENTS - 1];
        last.start + last.duration
    }

    /// The initial reference state (and the drone's initial state).
    pub fn start(&self) -> [f64; NX] {
        self.state_at(0.0)
    }

    /// Start time, duration and a short name of each pattern, for plots and docs.
    pub fn phases(&self) -> impl Iterator<Item = (f64, f64, &'static str)> + '_ {
        self.segments.iter().map(|s| {
            let name = match s.shape {
                Shape::Hold => "hover",
                Shape::Smooth { .. } => "climb/descent",
                Shape::Line { .. } => "straight leg",
                Shape::Circle { climb: 0.0, .. } => "circle",
                Shape::Circle { .. } => "helix",
                Shape::Eight { .. } => "figure eight",
            };
            (s.start, s.duration, name)
        })
    }
}

impl Reference for Trajectory {
    fn state_at(&self, t: f64) -> [f64; NX] {
        let t = if t > 0.0 { t } else { 0.0 };
        for seg in &self.segments {
            if t < seg.start + seg.duration {
                return seg.eval(t - seg.start);
            }
        }
        let last = &self.segments[SEGMENTS - 1];
        let end = last.eval(last.duration);
        [end[0], end[1], end[2], 0.0, 0.0, 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_are_continuous_and_velocities_match_positions() {
        let r = Trajectory::paper();
        assert!((r.duration() - 111.0).abs() < 1e-9);
        let h = 1e-6;
        let n = (r.duration() / 0.01) as usize;
        for i in 0..n {
            let t = i as f64 * 0.01 + 0.005;
            let (a, b) = (r.state_at(t - h), r.state_at(t + h));
            let x = r.state_at(t);
            for ax in 0..3 {
                // Central difference of the position equals the stated velocity away from corners.
                let fd = (b[ax] - a[ax]) / (2.0 * h);
                assert!(
                    (fd - x[ax + 3]).abs() < 1e-4,
                    "axis {ax} at t = {t}: {fd} vs {}",
                    x[ax + 3]
                );
            }
        }
        // At each segment boundary the position does not jump.
        for (start, _, _) in r.phases() {
            let (a, b) = (r.state_at(start - 1e-9), r.state_at(start + 1e-9));
            for ax in 0..3 {
                assert!((a[ax] - b[ax]).abs() < 1e-6, "jump at t = {start}");
            }
        }
        // Starts on the ground at rest and ends hovering.
        assert_eq!(r.start(), [0.0; 6]);
        let end = r.state_at(200.0);
        assert!(end[3..].iter().all(|v| *v == 0.0));
        assert!((end[2] - 6.0).abs() < 1e-9);
    }

    #[test]
    fn patterns_have_sensible_speeds() {
        let r = Trajectory::paper();
        let mut vmax: f64 = 0.0;
        for k in 0..(r.duration() / DT) as usize {
            let x = r.state(k);
            vmax = vmax.max(libm::sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5]));
        }
        assert!(vmax > 2.0 && vmax < 4.0, "{vmax}");
    }

    #[test]
    fn window_is_the_next_n_references() {
        let r = Trajectory::paper();
        let w: [[f32; 6]; 4] = r.window(1000);
        for (j, row) in w.iter().enumerate() {
            let x = r.state(1001 + j);
            for i in 0..6 {
                assert_eq!(row[i], x[i] as f32);
            }
        }
        let s = Step::paper();
        assert_eq!(s.state_at(0.99)[0], 0.0);
        assert_eq!(s.state_at(1.0)[0], 1.0);
        assert_eq!(
            Hover([1.0, 2.0, 3.0]).state(5),
            [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]
        );
    }
}
