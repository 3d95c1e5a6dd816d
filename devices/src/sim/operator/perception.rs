//! What the operator perceives, and the delay line that makes it act on what it perceived
//! a reaction time ago.

use nalgebra::Isometry3;

use crate::Wrench;

/// One perception of the operator, device base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Perception {
    /// When, s on the operator's clock.
    pub t_s: f64,
    /// Where the held object is: the end effector (haptic arm) or the avatar (SpaceMouse), m.
    pub pose: Isometry3<f64>,
    /// The wrench the device pushes the hand with (N, N·m), when the device renders force;
    /// `None` for an input-only device (the operator feels nothing).
    pub felt: Option<Wrench>,
}

/// A fixed-capacity ring of perceptions, sampled every `period_s`; [`DelayLine::delayed`]
/// gives the newest one at least `delay_s` old. Allocates once.
#[derive(Debug, Clone)]
pub(crate) struct DelayLine {
    ring: Vec<Perception>,
    /// Index of the next write.
    next: usize,
    len: usize,
    delay_s: f64,
}

impl DelayLine {
    /// A line holding `delay_s` (s) of perceptions taken every `period_s` (s).
    pub fn new(delay_s: f64, period_s: f64) -> Self {
        let capacity = (delay_s / period_s).ceil() as usize + 2;
        DelayLine {
            ring: Vec::with_capacity(capacity),
            next: 0,
            len: 0,
            delay_s,
        }
    }

    /// Records `p` (times must not decrease) and returns the newest perception taken at or
    /// before `p.t_s − delay_s`, or the oldest one held while the line fills.
    pub fn push(&mut self, p: Perception) -> Perception {
        let capacity = self.ring.capacity();
        if self.ring.len() < capacity {
            self.ring.push(p);
        } else {
            self.ring[self.next] = p;
        }
        self.next = (self.next + 1) % capacity;
        self.len = (self.len + 1).min(capacity);
        let due = p.t_s - self.delay_s;
        // Newest first: the first one old enough is the answer.
        let mut best = p;
        for k in 1..=self.len {
            let i = (self.next + capacity - k) % capacity;
            best = self.ring[i];
            if self.ring[i].t_s <= due + 1e-12 {
                break;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_s: f64) -> Perception {
        Perception {
            t_s,
            pose: Isometry3::translation(t_s, 0.0, 0.0),
            felt: None,
        }
    }

    #[test]
    fn gives_what_was_seen_a_delay_ago() {
        let mut line = DelayLine::new(0.15, 1e-3);
        let mut seen = Vec::new();
        for k in 0..1000 {
            seen.push(line.push(at(k as f64 * 1e-3)).t_s);
        }
        // While filling: the oldest (t = 0).
        assert_eq!(seen[100], 0.0);
        // Then exactly 150 ticks behind.
        for (k, t) in seen.iter().enumerate().skip(200) {
            assert!((t - (k as f64 * 1e-3 - 0.15)).abs() < 1e-9, "{k}");
        }
        // No delay: the perception itself.
        let mut line = DelayLine::new(0.0, 1e-3);
        assert_eq!(line.push(at(0.5)).t_s, 0.5);
    }
}
