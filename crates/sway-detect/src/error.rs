//! The one error of this crate: a configuration (sensors or detector options) that cannot
//! run. Every variant carries the offending numbers and names the key of the config.

/// A sensor configuration or detector options that cannot run, found when the sensors or
/// a detector are built (and when a sensor configuration is read from TOML). Keys are
/// those of the TOML form (`yaw_rate.noise_sd`, `band.low_hz`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// A rate, period or time that must be positive and finite is not.
    #[error("`{key}` must be positive and finite, got {value}")]
    NotPositive {
        /// the key of the value
        key: String,
        /// the offending value
        value: f64,
    },
    /// A standard deviation, step or threshold that must be non-negative and finite is not.
    #[error("`{key}` must be non-negative and finite, got {value}")]
    Negative {
        /// the key of the value
        key: String,
        /// the offending value
        value: f64,
    },
    /// A value that may have any sign (a constant bias) is NaN or infinite.
    #[error("`{key}` must be finite, got {value}")]
    NotFinite {
        /// the key of the value
        key: String,
        /// the offending value
        value: f64,
    },
    /// A channel samples faster than the controller reads its sensors.
    #[error(
        "`{channel}.sample_rate_hz` = {rate_hz} Hz exceeds the frame rate {frame_rate_hz} Hz \
         at which the controller reads its sensors"
    )]
    FasterThanFrame {
        /// the channel's key
        channel: &'static str,
        /// its sample rate \[Hz\]
        rate_hz: f64,
        /// the frame rate \[Hz\]
        frame_rate_hz: f64,
    },
    /// A latency longer than the sensor's fixed delay buffer.
    #[error("`{channel}.latency_samples` = {samples} exceeds the delay buffer's {max} samples")]
    LatencyTooLong {
        /// the channel's key
        channel: &'static str,
        /// the configured latency \[samples\]
        samples: usize,
        /// the longest latency the buffer holds \[samples\]
        max: usize,
    },
    /// The sway band is empty, starts at or below zero or reaches the Nyquist frequency.
    #[error(
        "sway band [{low_hz}, {high_hz}] Hz must satisfy 0 < low < high < {nyquist_hz} Hz \
         (the Nyquist frequency of the filter's sample rate)"
    )]
    Band {
        /// the band's lower edge \[Hz\]
        low_hz: f64,
        /// the band's upper edge \[Hz\]
        high_hz: f64,
        /// half the sample rate the filter runs at \[Hz\]
        nyquist_hz: f64,
    },
    /// A count or length outside the range its fixed-size buffer holds.
    #[error("`{key}` = {value} must be between {min} and {max}")]
    OutOfRange {
        /// the key of the value
        key: &'static str,
        /// the offending value
        value: usize,
        /// the smallest allowed value
        min: usize,
        /// the largest allowed value
        max: usize,
    },
    /// A value outside the open interval its model allows (a car's axle behind its hitch,
    /// a bound above its pair, a prior outside its bounds).
    #[error("`{key}` = {value} must lie in ({low}, {high})")]
    Bounds {
        /// the key of the value
        key: &'static str,
        /// the offending value
        value: f64,
        /// the interval's lower end
        low: f64,
        /// the interval's upper end
        high: f64,
    },
    /// The half-period window of the oscillation counter is empty.
    #[error("half-period window [{min_s}, {max_s}] s must satisfy 0 < min < max")]
    HalfPeriods {
        /// the shortest half-oscillation counted \[s\]
        min_s: f64,
        /// the longest half-oscillation counted \[s\]
        max_s: f64,
    },
    /// The estimator's autoregressive step reaches the sway band's Nyquist frequency: the
    /// band's upper edge would alias.
    #[error(
        "autoregressive step {step_s} s (`ar_lag_samples` = {lag}) is too long for the band's \
         upper edge {high_hz} Hz: it must be below 1/(2·{high_hz}) s"
    )]
    ArStep {
        /// the configured lag \[samples\]
        lag: usize,
        /// the step h = lag / sample rate \[s\]
        step_s: f64,
        /// the band's upper edge \[Hz\]
        high_hz: f64,
    },
    /// Two periods of the band's lower edge do not fit the estimator's history.
    #[error(
        "two periods of the band's lower edge {low_hz} Hz at {sample_rate_hz} Hz are \
         {samples} samples, beyond the estimator's history of {max}"
    )]
    PeriodTooLong {
        /// the band's lower edge \[Hz\]
        low_hz: f64,
        /// the sample rate \[Hz\]
        sample_rate_hz: f64,
        /// the samples needed
        samples: usize,
        /// the most the history holds
        max: usize,
    },
    /// The estimator's memory is shorter than two autoregressive steps.
    #[error("`memory_s` = {memory_s} s must be at least two autoregressive steps, {min_s} s")]
    MemoryTooShort {
        /// the configured memory \[s\]
        memory_s: f64,
        /// two autoregressive steps \[s\]
        min_s: f64,
    },
}

/// `value` if it is positive and finite.
pub(crate) fn positive(key: impl Into<String>, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ConfigError::NotPositive {
            key: key.into(),
            value,
        })
    }
}

/// `value` if it is non-negative and finite.
pub(crate) fn non_negative(key: impl Into<String>, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ConfigError::Negative {
            key: key.into(),
            value,
        })
    }
}

/// `value` if it is finite.
pub(crate) fn finite(key: impl Into<String>, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ConfigError::NotFinite {
            key: key.into(),
            value,
        })
    }
}

/// `value` if it lies in `[min, max]`.
pub(crate) fn in_range(
    key: &'static str,
    value: usize,
    min: usize,
    max: usize,
) -> Result<usize, ConfigError> {
    if (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange {
            key,
            value,
            min,
            max,
        })
    }
}
