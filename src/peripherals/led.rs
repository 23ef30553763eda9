//! The status LED on a GPIO: one blink pattern per node state. `no_std`, against the
//! `embedded-hal` 1.0 [`OutputPin`].
//!
//! | state | pattern (period) | meaning |
//! |---|---|---|
//! | booting | 100 ms on / 100 ms off (0.2 s) | reading flash, opening devices |
//! | commissioning | 500 ms on / 500 ms off (1 s) | capturing and computing the room model |
//! | serving | on | desk values published, every part healthy |
//! | degraded | 1800 ms on / 200 ms off (2 s) | serving, with a fault flagged in the status register (a peripheral, stale values, a damaged slot) |
//! | fault | 3 × (150 on / 150 off), 1100 ms off (2 s) | stopped: commissioning or the store failed; the log says why |
//!
//! [`StatusLed::tick`] is called with a millisecond clock; it drives the pin only on an edge, so
//! a slow caller never produces a wrong pattern, only a late edge.

use embedded_hal::digital::OutputPin;

/// What the node is doing, as the LED shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeState {
    /// Reading flash, opening devices.
    Booting,
    /// Capturing and computing the room model.
    Commissioning,
    /// Serving, every part healthy.
    Serving,
    /// Serving with a fault flagged.
    Degraded,
    /// Stopped by an error.
    Fault,
}

impl NodeState {
    /// The pattern: (on?, ms) phases, repeated.
    pub fn pattern(self) -> &'static [(bool, u32)] {
        match self {
            NodeState::Booting => &[(true, 100), (false, 100)],
            NodeState::Commissioning => &[(true, 500), (false, 500)],
            NodeState::Serving => &[(true, 1000)],
            NodeState::Degraded => &[(true, 1800), (false, 200)],
            NodeState::Fault => &[
                (true, 150),
                (false, 150),
                (true, 150),
                (false, 150),
                (true, 150),
                (false, 1250),
            ],
        }
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            NodeState::Booting => "booting",
            NodeState::Commissioning => "commissioning",
            NodeState::Serving => "serving",
            NodeState::Degraded => "degraded",
            NodeState::Fault => "fault",
        }
    }

    /// Whether the LED is on `t_ms` into the pattern.
    pub fn level_at(self, t_ms: u64) -> bool {
        let p = self.pattern();
        let period: u64 = p.iter().map(|x| u64::from(x.1)).sum();
        let mut t = t_ms % period.max(1);
        for &(on, ms) in p {
            if t < u64::from(ms) {
                return on;
            }
            t -= u64::from(ms);
        }
        false
    }
}

/// The LED on a pin (`active_high`: the pin high lights it).
#[derive(Debug)]
pub struct StatusLed<P> {
    pin: P,
    active_high: bool,
    state: NodeState,
    since_ms: u64,
    level: Option<bool>,
}

impl<P: OutputPin> StatusLed<P> {
    /// The LED, in state booting from `now_ms`.
    pub fn new(pin: P, active_high: bool, now_ms: u64) -> Self {
        Self {
            pin,
            active_high,
            state: NodeState::Booting,
            since_ms: now_ms,
            level: None,
        }
    }

    /// The state shown.
    pub fn state(&self) -> NodeState {
        self.state
    }

    /// Shows `state` from `now_ms` (a new state starts its pattern from the beginning).
    pub fn set_state(&mut self, state: NodeState, now_ms: u64) {
        if state != self.state {
            self.state = state;
            self.since_ms = now_ms;
        }
    }

    /// Drives the pin for `now_ms`; returns the LED's level (true = lit).
    pub fn tick(&mut self, now_ms: u64) -> Result<bool, P::Error> {
        let on = self.state.level_at(now_ms.saturating_sub(self.since_ms));
        if self.level != Some(on) {
            if on == self.active_high {
                self.pin.set_high()?;
            } else {
                self.pin.set_low()?;
            }
            self.level = Some(on);
        }
        Ok(on)
    }

    /// The pin back.
    pub fn release(self) -> P {
        self.pin
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_have_the_documented_periods_and_duty() {
        for (s, period, on) in [
            (NodeState::Booting, 200, 100),
            (NodeState::Commissioning, 1000, 500),
            (NodeState::Serving, 1000, 1000),
            (NodeState::Degraded, 2000, 1800),
            (NodeState::Fault, 2000, 450),
        ] {
            let p = s.pattern();
            assert_eq!(p.iter().map(|x| x.1).sum::<u32>(), period, "{s:?}");
            assert_eq!(
                p.iter().filter(|x| x.0).map(|x| x.1).sum::<u32>(),
                on,
                "{s:?}"
            );
            // sampled every ms over two periods: the duty is the pattern's
            let lit = (0..2 * u64::from(period))
                .filter(|&t| s.level_at(t))
                .count();
            assert_eq!(lit as u32, 2 * on, "{s:?}");
        }
    }
}
