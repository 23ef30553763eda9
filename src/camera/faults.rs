//! Fault injection for any camera (after smoltcp's `phy::FaultInjector`): wraps a driver and,
//! per capture call, turns it into a timeout, a garbage frame or (after a number of delivered
//! frames) a permanent disconnect, either at random with its own seeded generator or at given
//! call indices. The errors are exactly the ones the real drivers report, so code that survives
//! the injector survives the hardware.

use std::time::Duration;

use super::{CameraError, DepthCamera, DepthFrame, LuminanceCamera, LuminanceFrame};
use crate::rng::SplitMix64;

/// What to inject. Call indices count capture calls from 0 (attempts, including failed ones).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Faults {
    /// Seed of the injector's own generator.
    pub seed: u64,
    /// Chance that a call times out.
    pub timeout_chance: f64,
    /// Chance that a call returns a garbage frame.
    pub garbage_chance: f64,
    /// Calls that time out.
    pub timeout_at: Vec<u64>,
    /// Calls that return garbage.
    pub garbage_at: Vec<u64>,
    /// After this many delivered frames the device is gone (until [`FaultInjector::reconnect`]).
    pub disconnect_after_frames: Option<u64>,
    /// How long an injected timeout blocks before it returns, s (0: at once; a real driver
    /// blocks for its timeout).
    pub timeout_delay_s: f64,
}

impl Faults {
    /// No faults.
    pub fn none() -> Self {
        Self::default()
    }

    /// Checks the chances and the delay.
    pub fn validate(&self) -> Result<(), CameraError> {
        for (name, p) in [
            ("timeout_chance", self.timeout_chance),
            ("garbage_chance", self.garbage_chance),
        ] {
            if !(0.0..=1.0).contains(&p) {
                return Err(CameraError::Config(format!(
                    "faults.{name} {p} is outside [0, 1]"
                )));
            }
        }
        if !(self.timeout_delay_s.is_finite() && (0.0..=60.0).contains(&self.timeout_delay_s)) {
            return Err(CameraError::Config(format!(
                "faults.timeout_delay_s {} is outside [0, 60] s",
                self.timeout_delay_s
            )));
        }
        Ok(())
    }
}

/// A camera with injected faults.
pub struct FaultInjector<C> {
    inner: C,
    faults: Faults,
    rng: SplitMix64,
    device: String,
    calls: u64,
    delivered: u64,
    disconnected: bool,
}

impl<C> FaultInjector<C> {
    /// Wraps `inner`; `device` names it in errors.
    pub fn new(inner: C, faults: Faults, device: &str) -> Result<Self, CameraError> {
        faults.validate()?;
        Ok(Self {
            inner,
            rng: SplitMix64::new(faults.seed ^ 0xFA17_FA17_FA17_FA17),
            faults,
            device: device.to_owned(),
            calls: 0,
            delivered: 0,
            disconnected: false,
        })
    }

    /// The wrapped camera.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The wrapped camera, mutable.
    pub fn inner_mut(&mut self) -> &mut C {
        &mut self.inner
    }

    /// Capture calls so far (attempts).
    pub fn calls(&self) -> u64 {
        self.calls
    }

    /// Frames delivered so far.
    pub fn delivered(&self) -> u64 {
        self.delivered
    }

    /// Plugs the device back in: clears the disconnect and restarts the delivered-frame count.
    pub fn reconnect(&mut self) {
        self.disconnected = false;
        self.delivered = 0;
    }

    /// Decides the fault of the next call, if any (always draws both numbers, so the sequence
    /// of faults depends only on the seed and the call index).
    fn fault(&mut self) -> Option<CameraError> {
        let call = self.calls;
        self.calls += 1;
        let r_timeout = self.rng.next_f64();
        let r_garbage = self.rng.next_f64();
        if self.disconnected
            || self
                .faults
                .disconnect_after_frames
                .is_some_and(|n| self.delivered >= n)
        {
            self.disconnected = true;
            return Some(CameraError::Disconnected {
                device: self.device.clone(),
                reason: format!("injected: gone after {} frames", self.delivered),
            });
        }
        if self.faults.timeout_at.contains(&call) || r_timeout < self.faults.timeout_chance {
            if self.faults.timeout_delay_s > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(self.faults.timeout_delay_s));
            }
            return Some(CameraError::Timeout {
                device: self.device.clone(),
                timeout_s: self.faults.timeout_delay_s,
            });
        }
        if self.faults.garbage_at.contains(&call) || r_garbage < self.faults.garbage_chance {
            return Some(CameraError::Garbage {
                device: self.device.clone(),
                reason: format!("injected: checksum mismatch in frame of call {call}"),
            });
        }
        None
    }
}

impl<C: DepthCamera> DepthCamera for FaultInjector<C> {
    fn camera(&self) -> &crate::scene::Camera {
        self.inner.camera()
    }
    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        if let Some(e) = self.fault() {
            return Err(e);
        }
        let f = self.inner.capture_depth()?;
        self.delivered += 1;
        Ok(f)
    }
}

impl<C: LuminanceCamera> LuminanceCamera for FaultInjector<C> {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        if let Some(e) = self.fault() {
            return Err(e);
        }
        let f = self.inner.capture_luminance()?;
        self.delivered += 1;
        Ok(f)
    }
}
