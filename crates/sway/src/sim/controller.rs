//! Steering controllers: none, or the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) of
//! paper eq. (8), switched on at t_on and optionally off at t_off.

use serde::{Deserialize, Serialize};

/// The steering law.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Controller {
    /// δ ≡ 0 (open loop).
    #[default]
    None,
    /// δ(t) = −D·ψ̇(t − τ) for t_on ≤ t < t_off, 0 otherwise (paper eq. 8).
    YawRateFeedback {
        /// control gain D \[s\]
        gain_s: f64,
        /// feedback delay τ \[s\] (sensing, computation, actuation; 0.2–0.4 s in production cars)
        delay_s: f64,
        /// t_on \[s\]: switched on
        #[serde(default)]
        on_s: f64,
        /// t_off \[s\]: switched off (never when absent)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        off_s: Option<f64>,
    },
}

impl Controller {
    /// The delay τ \[s\] of the loop, if there is a loop.
    pub fn delay(&self) -> Option<f64> {
        match self {
            Controller::None => None,
            Controller::YawRateFeedback { delay_s, .. } => Some(*delay_s),
        }
    }

    /// Steering angle δ(t) \[rad\] given the delayed yaw rate ψ̇(t − τ) \[rad/s\].
    #[inline]
    pub fn steering_angle(&self, t: f64, delayed_yaw_rate: f64) -> f64 {
        match self {
            Controller::None => 0.0,
            Controller::YawRateFeedback {
                gain_s,
                on_s,
                off_s,
                ..
            } => {
                if t >= *on_s && off_s.is_none_or(|off| t < off) {
                    -gain_s * delayed_yaw_rate
                } else {
                    0.0
                }
            }
        }
    }

    /// Times \[s\] where δ may jump (switching on and off).
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            Controller::None => Vec::new(),
            Controller::YawRateFeedback { on_s, off_s, .. } => {
                let mut v = vec![*on_s];
                v.extend(off_s.iter());
                v
            }
        }
    }

    /// When the controller is switched on, if ever.
    pub fn action_time(&self) -> Option<f64> {
        match self {
            Controller::None => None,
            Controller::YawRateFeedback { on_s, .. } => Some(*on_s),
        }
    }

    /// Checks; `Err((key, problem))` names the offending key.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if let Controller::YawRateFeedback {
            gain_s,
            delay_s,
            on_s,
            off_s,
        } = self
        {
            if !gain_s.is_finite() {
                return Err(("gain_s", format!("expected a finite gain, got {gain_s}")));
            }
            if !(delay_s.is_finite() && *delay_s >= 0.0) {
                return Err(("delay_s", format!("expected a delay >= 0 s, got {delay_s}")));
            }
            if !(on_s.is_finite() && *on_s >= 0.0) {
                return Err(("on_s", format!("expected a time >= 0 s, got {on_s}")));
            }
            if let Some(off) = off_s
                && !(off.is_finite() && off > on_s)
            {
                return Err((
                    "off_s",
                    format!("expected off_s > on_s = {on_s}, got {off}"),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn switching_window_is_right_continuous() {
        let c = Controller::YawRateFeedback {
            gain_s: 0.1,
            delay_s: 0.2,
            on_s: 10.0,
            off_s: Some(20.0),
        };
        assert_eq!(c.steering_angle(9.999, 1.0), 0.0);
        assert_eq!(c.steering_angle(10.0, 1.0), -0.1);
        assert_eq!(c.steering_angle(19.999, -2.0), 0.2);
        assert_eq!(c.steering_angle(20.0, 1.0), 0.0);
        assert_eq!(c.breakpoints(), vec![10.0, 20.0]);
    }
}
