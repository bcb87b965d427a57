//! The clock table of a keyframe path: the other clock (proper time for `clock = "world"`,
//! world time for `clock = "proper"`) tabulated along the path by integrating its rate
//! (`dtau = dt / gamma`, or `dt = sqrt(1 + u^2/c^2) dtau` for the proper velocity `u`) with
//! 5-point Gauss-Legendre over [`SUB`] sub-intervals per segment, and its inverse by a
//! safeguarded Newton search. Proper time of a frame to (path-clock time, world time) goes
//! through here (physics.md, "Units and clocks").

use super::keyframes::KeyTrack;
use super::Clock;
use crate::units::C_M_PER_PS;
use nalgebra::Vector3;

/// Sub-intervals per keyframe segment of the clock table (5-point Gauss-Legendre each).
const SUB: usize = 32;
const GL5_X: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];
const GL5_W: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

/// The integral of `f` over `[a, b]` by 5-point Gauss-Legendre.
fn gauss_legendre(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (m, r) = (0.5 * (a + b), 0.5 * (b - a));
    r * GL5_X
        .iter()
        .zip(GL5_W.iter())
        .map(|(x, w)| w * f(m + r * x))
        .sum::<f64>()
}

impl KeyTrack {
    /// Rate of the other clock per unit of the path clock at `s`.
    pub(super) fn rate(&self, s: f64) -> f64 {
        let (_, vel) = self.position_velocity(s);
        let b2 = vel.norm_squared() / (C_M_PER_PS * C_M_PER_PS);
        match self.clock {
            Clock::World => (1.0 - b2).max(0.0).sqrt(),
            Clock::Proper => (1.0 + b2).sqrt(),
        }
    }

    fn node_s(&self, node: usize) -> f64 {
        let i = (node / SUB).min(self.n() - 2);
        let j = node - i * SUB;
        let h = self.knots[i + 1] - self.knots[i];
        self.knots[i] + h * j as f64 / SUB as f64
    }

    pub(super) fn build_table(&mut self) {
        let n = self.n();
        if n == 1 {
            self.cum = vec![self.knots[0]];
            return;
        }
        let nodes = (n - 1) * SUB + 1;
        let mut cum = Vec::with_capacity(nodes);
        cum.push(self.knots[0]);
        for node in 0..nodes - 1 {
            let (a, b) = (self.node_s(node), self.node_s(node + 1));
            let (a, b) = if node % SUB == SUB - 1 {
                (a, self.knots[node / SUB + 1])
            } else {
                (a, b)
            };
            // Evaluate inside the segment of `node` (matters at the knots for linear paths).
            let last = cum[node];
            cum.push(last + gauss_legendre(a, b, |s| self.rate(s)));
        }
        self.cum = cum;
    }

    /// The other clock at path-clock time `s` (clamped to the span).
    pub(super) fn other_at(&self, s: f64) -> f64 {
        if self.n() == 1 {
            return s;
        }
        let s = s.clamp(self.knots[0], self.knots[self.n() - 1]);
        let (i, _) = self.locate(s);
        let h = self.knots[i + 1] - self.knots[i];
        let j = (((s - self.knots[i]) / h * SUB as f64).floor() as usize).min(SUB - 1);
        let node = i * SUB + j;
        let a = self.node_s(node);
        self.cum[node] + gauss_legendre(a, s, |x| self.rate(x))
    }

    /// Path-clock time at which the other clock reads `other` (clamped to the span).
    pub(super) fn s_at_other(&self, other: f64) -> f64 {
        if self.n() == 1 {
            return other;
        }
        let last = self.cum.len() - 1;
        if other <= self.cum[0] {
            return self.knots[0];
        }
        if other >= self.cum[last] {
            return self.knots[self.n() - 1];
        }
        let node = self.cum.partition_point(|&c| c <= other).saturating_sub(1);
        let i = (node / SUB).min(self.n() - 2);
        let (mut lo, mut hi) = (
            self.node_s(node),
            if node % SUB == SUB - 1 {
                self.knots[i + 1]
            } else {
                self.node_s(node + 1)
            },
        );
        let base = self.cum[node];
        let a = lo;
        let f = |s: f64| base + gauss_legendre(a, s, |x| self.rate(x)) - other;
        let mut s = lo + (hi - lo) * 0.5;
        for _ in 0..100 {
            let fs = f(s);
            if fs.abs() <= 1e-13 * (1.0 + other.abs()) {
                break;
            }
            if fs > 0.0 {
                hi = s;
            } else {
                lo = s;
            }
            if hi - lo <= 1e-13 * (1.0 + s.abs()) {
                s = 0.5 * (lo + hi);
                break;
            }
            let r = self.rate(s);
            let newton = s - fs / r;
            s = if r > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
        }
        s
    }

    /// Proper time span `[tau_first, tau_last]` of the keyframes.
    pub(super) fn tau_span(&self) -> (f64, f64) {
        let n = self.n();
        match self.clock {
            Clock::Proper => (self.knots[0], self.knots[n - 1]),
            Clock::World => (self.cum[0], self.cum[self.cum.len() - 1]),
        }
    }

    /// (path-clock time, world time) at proper time `tau`.
    pub(super) fn times_at_tau(&self, tau: f64) -> (f64, f64) {
        if self.n() == 1 {
            // World time equals proper time at the keyframe; a moving keyframe's clock runs
            // slow by gamma (dt = gamma dtau), and the path clock is proper or world time.
            let beta = self.beta_from_derivative(&self.tangents[0]);
            if beta == Vector3::zeros() || tau == self.knots[0] {
                return (tau, tau);
            }
            let t = self.knots[0] + crate::relativity::gamma(beta.norm()) * (tau - self.knots[0]);
            return match self.clock {
                Clock::Proper => (tau, t),
                Clock::World => (t, t),
            };
        }
        match self.clock {
            Clock::Proper => (tau, self.other_at(tau)),
            Clock::World => {
                let s = self.s_at_other(tau);
                (s, s)
            }
        }
    }
}
