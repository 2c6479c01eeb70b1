//! Durations on the command line: checked when parsed, so that no value (`inf`, `1e30`, `nan`) can reach
//! `std::time::Duration`, which panics on them.

/// The longest duration an option takes (s): about eleven days.
pub const MAX_SECONDS: f64 = 1e6;

/// A clap value parser for seconds: a finite number from 0 to [`MAX_SECONDS`].
pub fn seconds(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("{text:?} is not a number of seconds"))?;
    if value.is_finite() && (0.0..=MAX_SECONDS).contains(&value) {
        Ok(value)
    } else {
        Err(format!("{text} s: must be from 0 to {MAX_SECONDS} s"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_finite_durations_in_range_are_taken() {
        assert_eq!(seconds("2.5"), Ok(2.5));
        assert_eq!(seconds("0"), Ok(0.0));
        for bad in ["inf", "-1", "1e30", "nan", "x", "1e7"] {
            assert!(seconds(bad).is_err(), "{bad}");
        }
    }
}
