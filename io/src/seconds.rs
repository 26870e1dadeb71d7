//! Durations a person writes in seconds, on a command line (`--run-for 1.5`) or in a
//! configuration file (`peer_expiry = 10.0`): one rule and one message for both.

use std::time::Duration;

/// The longest any program here waits or runs, in seconds: 10^9 s, about 31 years.
pub const MAX: f64 = 1e9;

/// What a number of seconds may be.
const RANGE: &str = "use a number of seconds from 0 to 1e9 (about 31 years), e.g. 10 or 0.5";

/// Seconds as read from a file: from 0 to [`MAX`] (NaN and infinities are refused).
pub fn from_f64(s: f64) -> Result<Duration, String> {
    if (0.0..=MAX).contains(&s) {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(RANGE.into())
    }
}

/// Seconds as typed on a command line (a clap value parser): a decimal number from 0 to
/// [`MAX`].
pub fn parse(text: &str) -> Result<Duration, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| RANGE.to_string())
        .and_then(from_f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_from_zero_to_a_billion() {
        assert_eq!(parse("0"), Ok(Duration::ZERO));
        assert_eq!(parse("1.5"), Ok(Duration::from_millis(1500)));
        assert_eq!(parse("1e9"), Ok(Duration::from_secs(1_000_000_000)));
        for bad in ["-1", "1e300", "inf", "NaN", "", "ten", "10s"] {
            assert_eq!(parse(bad), Err(RANGE.to_string()), "{bad}");
        }
        assert!(from_f64(f64::NAN).is_err());
        assert!(from_f64(-0.001).is_err());
        assert_eq!(parse("-0"), Ok(Duration::ZERO));
    }
}
