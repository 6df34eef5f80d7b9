//! How a number prints where a user reads it: positionally while that is
//! short, in scientific notation where it would run to many digits or
//! round to zero, so a message never holds a 300-digit pressure or calls
//! a 1e-7 edge "0.0000".

use std::fmt;

/// A number as a message shows it. `{}` gives the shortest form that
/// reads back to the same value; `{:.p}` gives `p` decimals, or `p`
/// decimals of the mantissa where the value is at least 1e9 in size or
/// would show fewer than one significant digit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

/// Sizes from this up to [`POSITIONAL_BELOW`] print positionally when no
/// precision is asked for.
const POSITIONAL_FROM: f64 = 1e-4;
/// Sizes from this up print in scientific notation.
const POSITIONAL_BELOW: f64 = 1e9;

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let size = x.abs();
        if !x.is_finite() || x == 0.0 {
            return match f.precision() {
                Some(p) if x == 0.0 => write!(f, "{x:.p$}"),
                _ => write!(f, "{x}"),
            };
        }
        match f.precision() {
            None if (POSITIONAL_FROM..POSITIONAL_BELOW).contains(&size) => write!(f, "{x}"),
            None => write!(f, "{x:e}"),
            Some(p) if size < POSITIONAL_BELOW && size >= 10f64.powi(-(p as i32)) => {
                write!(f, "{x:.p$}")
            }
            Some(p) => write!(f, "{x:.p$e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Num;

    #[test]
    fn short_numbers_print_as_written_and_long_ones_in_scientific_notation() {
        assert_eq!(Num(0.55).to_string(), "0.55");
        assert_eq!(Num(12.0).to_string(), "12");
        assert_eq!(Num(-3.25).to_string(), "-3.25");
        assert_eq!(Num(0.0).to_string(), "0");
        assert_eq!(Num(1e100).to_string(), "1e100");
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(2.5e-7).to_string(), "2.5e-7");
        assert_eq!(Num(f64::INFINITY).to_string(), "inf");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
    }

    #[test]
    fn a_precision_never_rounds_a_value_to_zero_or_to_hundreds_of_digits() {
        assert_eq!(format!("{:.4}", Num(0.5)), "0.5000");
        assert_eq!(format!("{:.4}", Num(0.0)), "0.0000");
        assert_eq!(format!("{:.4}", Num(3e-7)), "3.0000e-7");
        assert_eq!(format!("{:.4}", Num(1e300)), "1.0000e300");
        assert_eq!(format!("{:.2}", Num(123456.789)), "123456.79");
        assert_eq!(format!("{:.1}", Num(-0.05)), "-5.0e-2");
    }
}
