//! Exact polynomial arithmetic: rationals on `i128` and canonical sparse
//! polynomials over them.
//!
//! Everything the macro checks (skew-symmetry, the Jacobi identity, whether a
//! reference model fits the bases) is a polynomial identity, so it is decided
//! exactly here rather than with floating point. Overflow of the `i128`
//! numerators and denominators is detected and reported, never wrapped.

use std::collections::BTreeMap;
use std::fmt;

/// Arithmetic left the range of exact `i128` rationals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Overflow;

impl fmt::Display for Overflow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(
            "exact rational arithmetic overflowed 128-bit integers: a coefficient's numerator \
             or denominator passed about 1.7e38 (a product of very large or very small numbers, \
             or of numbers with many digits); rescale the state variables so that the \
             coefficients are moderate, or write them with fewer digits",
        )
    }
}

/// Result of exact arithmetic.
pub type Exact<T> = Result<T, Overflow>;

/// An exact rational number in lowest terms with a positive denominator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rational {
    num: i128,
    den: i128,
}

fn gcd(mut a: i128, mut b: i128) -> i128 {
    // Works on magnitudes; `unsigned_abs` avoids overflow on i128::MIN.
    a = a.checked_abs().unwrap_or(i128::MAX);
    b = b.checked_abs().unwrap_or(i128::MAX);
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Rational {
    /// Zero.
    pub const ZERO: Rational = Rational { num: 0, den: 1 };
    /// One.
    pub const ONE: Rational = Rational { num: 1, den: 1 };

    /// `num / den` in lowest terms; `None` if `den == 0` or on overflow.
    pub fn new(num: i128, den: i128) -> Exact<Option<Rational>> {
        if den == 0 {
            return Ok(None);
        }
        if num == i128::MIN || den == i128::MIN {
            return Err(Overflow);
        }
        let g = gcd(num, den).max(1);
        let (mut num, mut den) = (num / g, den / g);
        if den < 0 {
            num = -num;
            den = -den;
        }
        Ok(Some(Rational { num, den }))
    }

    /// The integer `n`.
    pub fn integer(n: i128) -> Rational {
        Rational { num: n, den: 1 }
    }

    /// Numerator (sign carrier).
    pub fn numerator(self) -> i128 {
        self.num
    }

    /// Denominator (always positive).
    pub fn denominator(self) -> i128 {
        self.den
    }

    /// Whether this is zero.
    pub fn is_zero(self) -> bool {
        self.num == 0
    }

    /// The value as an integer, if it is one.
    pub fn as_integer(self) -> Option<i128> {
        (self.den == 1).then_some(self.num)
    }

    /// Nearest `f64`, ties to even. `num as f64 / den as f64` rounds twice
    /// once either exceeds 2⁵³ (a literal of 17 or more digits), and was a
    /// unit in the last place off for about a third of them (a probe:
    /// `1.602176634e-19` came out as `1.6021766340000001e-19`).
    pub fn to_f64(self) -> f64 {
        if self.num == 0 {
            return 0.0;
        }
        // Every non-zero |num/den| lies in [2⁻¹²⁷, 2¹²⁷): a normal f64.
        let (num, den) = (self.num.unsigned_abs(), self.den.unsigned_abs());
        // 64 significant bits of the quotient, value = mantissa · 2^exponent,
        // and whether anything non-zero lies below them.
        let (mut mantissa, mut remainder) = (num / den, num % den);
        let mut exponent: i32 = 0;
        while mantissa < 1 << 63 {
            // remainder < den < 2¹²⁷, so doubling it stays in u128.
            remainder <<= 1;
            mantissa <<= 1;
            if remainder >= den {
                remainder -= den;
                mantissa |= 1;
            }
            exponent -= 1;
        }
        let mut inexact = remainder != 0;
        let excess = (128 - mantissa.leading_zeros()).saturating_sub(64);
        if excess > 0 {
            inexact |= mantissa & ((1 << excess) - 1) != 0;
            mantissa >>= excess;
            exponent += excess as i32;
        }
        // The lowest of 64 bits is far below the f64's rounding bit: set,
        // it turns an exact tie into "above" exactly when the bits dropped
        // were not all zero, so the one rounding of `as f64` is the right one.
        let bits = mantissa as u64 | u64::from(inexact);
        let power = f64::from_bits(((exponent + 1023) as u64) << 52);
        let magnitude = bits as f64 * power;
        if self.num < 0 {
            -magnitude
        } else {
            magnitude
        }
    }

    /// `self + other`.
    pub fn add(self, other: Rational) -> Exact<Rational> {
        let g = gcd(self.den, other.den).max(1);
        let left = self.num.checked_mul(other.den / g).ok_or(Overflow)?;
        let right = other.num.checked_mul(self.den / g).ok_or(Overflow)?;
        let num = left.checked_add(right).ok_or(Overflow)?;
        let den = (self.den / g).checked_mul(other.den).ok_or(Overflow)?;
        Rational::new(num, den).map(|r| r.unwrap_or(Rational::ZERO))
    }

    /// `-self`.
    pub fn neg(self) -> Exact<Rational> {
        Ok(Rational {
            num: self.num.checked_neg().ok_or(Overflow)?,
            den: self.den,
        })
    }

    /// `self - other`.
    pub fn sub(self, other: Rational) -> Exact<Rational> {
        self.add(other.neg()?)
    }

    /// `self * other`.
    pub fn mul(self, other: Rational) -> Exact<Rational> {
        // Cross-cancel first so that products stay small.
        let g1 = gcd(self.num, other.den).max(1);
        let g2 = gcd(other.num, self.den).max(1);
        let num = (self.num / g1)
            .checked_mul(other.num / g2)
            .ok_or(Overflow)?;
        let den = (self.den / g2)
            .checked_mul(other.den / g1)
            .ok_or(Overflow)?;
        Rational::new(num, den).map(|r| r.unwrap_or(Rational::ZERO))
    }

    /// `self / other`; `None` when `other` is zero.
    pub fn div(self, other: Rational) -> Exact<Option<Rational>> {
        if other.is_zero() {
            return Ok(None);
        }
        let inverse = Rational::new(other.den, other.num)?.ok_or(Overflow)?;
        self.mul(inverse).map(Some)
    }

    /// `self^exponent`.
    pub fn pow(self, exponent: u32) -> Exact<Rational> {
        let mut result = Rational::ONE;
        for _ in 0..exponent {
            result = result.mul(self)?;
        }
        Ok(result)
    }

    /// Parses the decimal digits of a Rust literal: `12`, `0.25`, `1e-3`,
    /// `2.5E+4` (underscores already removed). `Ok(None)` if malformed;
    /// `Err` says why a well-formed literal is not an `i128` rational.
    pub fn parse_decimal(text: &str) -> Result<Option<Rational>, DecimalRange> {
        let (mantissa, exponent) = match text.find(['e', 'E']) {
            Some(at) => (&text[..at], Some(&text[at + 1..])),
            None => (text, None),
        };
        let exponent: i64 = match exponent {
            Some(e) => match e.parse() {
                Ok(e) => e,
                Err(_) => return Ok(None),
            },
            None => 0,
        };
        let (int_part, frac_part) = match mantissa.find('.') {
            Some(at) => (&mantissa[..at], &mantissa[at + 1..]),
            None => (mantissa, ""),
        };
        if int_part.is_empty() && frac_part.is_empty() {
            return Ok(None);
        }
        let mut digits = Vec::with_capacity(int_part.len() + frac_part.len());
        for c in int_part.chars().chain(frac_part.chars()) {
            let Some(d) = c.to_digit(10) else {
                return Ok(None);
            };
            digits.push(d);
        }
        // value = digits · 10^scale
        let Some(mut scale) = i64::try_from(frac_part.len())
            .ok()
            .and_then(|digits| exponent.checked_sub(digits))
        else {
            return Err(DecimalRange::Small { places: None });
        };
        // Trailing zeros move into the exponent, so that `1.000…0` with 40
        // digits or `0e400` is not an overflow: only values that are not
        // representable are.
        while digits.last() == Some(&0) {
            digits.pop();
            scale = scale.checked_add(1).ok_or(DecimalRange::Large)?;
        }
        // Leading zeros are no significant digits either (`0.001`).
        let leading = digits.iter().take_while(|&&d| d == 0).count();
        let digits = &digits[leading..];
        if digits.is_empty() {
            return Ok(Some(Rational::ZERO));
        }
        let mut num: i128 = 0;
        for &d in digits {
            num = num
                .checked_mul(10)
                .and_then(|n| n.checked_add(i128::from(d)))
                .ok_or(if scale >= 0 {
                    DecimalRange::Large
                } else {
                    DecimalRange::Digits
                })?;
        }
        let out_of_range = if scale >= 0 {
            DecimalRange::Large
        } else {
            DecimalRange::Small {
                places: Some(scale.unsigned_abs()),
            }
        };
        let power = u32::try_from(scale.unsigned_abs())
            .ok()
            .and_then(|k| Rational::integer(10).pow(k).ok())
            .ok_or(out_of_range)?;
        let value = Rational::integer(num);
        if scale >= 0 {
            value.mul(power).map(Some).map_err(|_| out_of_range)
        } else {
            value.div(power).map_err(|_| out_of_range)
        }
    }
}

/// Why a decimal literal is not an exact `i128` rational.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecimalRange {
    /// Its magnitude is beyond `i128` (about 1.7e38).
    Large,
    /// It has more than 38 decimal places (`places`, if that count fits a
    /// u64): its denominator 10^k is beyond `i128`, whatever its magnitude
    /// (`1.054571817e-34` has 43).
    Small {
        /// Decimal places after trailing zeros moved into the exponent.
        places: Option<u64>,
    },
    /// Its significant digits do not fit an `i128` numerator.
    Digits,
}

impl fmt::Display for Rational {
    /// Integers as integers, terminating fractions as decimals (`0.25`),
    /// others as `n/d`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 {
            return write!(f, "{}", self.num);
        }
        let (mut d, mut twos, mut fives) = (self.den, 0u32, 0u32);
        while d % 2 == 0 {
            d /= 2;
            twos += 1;
        }
        while d % 5 == 0 {
            d /= 5;
            fives += 1;
        }
        if d != 1 {
            return write!(f, "{}/{}", self.num, self.den);
        }
        let digits = twos.max(fives);
        // num/den = num * 2^(digits-twos) * 5^(digits-fives) / 10^digits.
        let scaled = 2i128
            .checked_pow(digits - twos)
            .and_then(|a| {
                5i128
                    .checked_pow(digits - fives)
                    .and_then(|b| a.checked_mul(b))
            })
            .and_then(|m| self.num.checked_mul(m));
        match scaled {
            Some(scaled) => {
                let sign = if scaled < 0 { "-" } else { "" };
                let magnitude = scaled.unsigned_abs().to_string();
                let width = digits as usize + 1;
                let padded = format!("{magnitude:0>width$}");
                let (int, frac) = padded.split_at(padded.len() - digits as usize);
                write!(f, "{sign}{int}.{frac}")
            }
            None => write!(f, "{}/{}", self.num, self.den),
        }
    }
}

/// An exponent vector, one entry per state variable.
pub type Exponents = Vec<u32>;

/// A polynomial in `nvars` variables: a sparse map from exponent vectors to
/// non-zero exact coefficients (zero coefficients are never stored, so two
/// equal polynomials have equal maps).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Polynomial {
    nvars: usize,
    terms: BTreeMap<Exponents, Rational>,
}

impl Polynomial {
    /// The zero polynomial.
    pub fn zero(nvars: usize) -> Polynomial {
        Polynomial {
            nvars,
            terms: BTreeMap::new(),
        }
    }

    /// A constant.
    pub fn constant(nvars: usize, value: Rational) -> Polynomial {
        let mut p = Polynomial::zero(nvars);
        if !value.is_zero() {
            p.terms.insert(vec![0; nvars], value);
        }
        p
    }

    /// `coefficient · x^exponents`.
    pub fn monomial(exponents: Exponents, coefficient: Rational) -> Polynomial {
        let mut p = Polynomial::zero(exponents.len());
        if !coefficient.is_zero() {
            p.terms.insert(exponents, coefficient);
        }
        p
    }

    /// The variable `x_index`.
    pub fn variable(nvars: usize, index: usize) -> Polynomial {
        let mut exponents = vec![0; nvars];
        exponents[index] = 1;
        let mut p = Polynomial::zero(nvars);
        p.terms.insert(exponents, Rational::ONE);
        p
    }

    /// Non-zero terms, in lexicographic order of exponents.
    pub fn terms(&self) -> impl Iterator<Item = (&Exponents, Rational)> + '_ {
        self.terms.iter().map(|(e, c)| (e, *c))
    }

    /// Number of non-zero terms.
    pub fn term_count(&self) -> usize {
        self.terms.len()
    }

    /// Coefficient of a monomial (zero if absent).
    pub fn coefficient(&self, exponents: &[u32]) -> Rational {
        self.terms.get(exponents).copied().unwrap_or(Rational::ZERO)
    }

    /// Whether every coefficient is zero.
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    /// The value if the polynomial is constant (no variable appears).
    pub fn as_constant(&self) -> Option<Rational> {
        match self.terms.len() {
            0 => Some(Rational::ZERO),
            1 => self
                .terms
                .iter()
                .next()
                .filter(|(e, _)| e.iter().all(|&k| k == 0))
                .map(|(_, c)| *c),
            _ => None,
        }
    }

    /// Total degree (0 for the zero polynomial).
    pub fn degree(&self) -> u32 {
        self.terms
            .keys()
            .map(|e| e.iter().sum::<u32>())
            .max()
            .unwrap_or(0)
    }

    /// Whether variable `index` appears in some term.
    pub fn uses_variable(&self, index: usize) -> bool {
        self.terms.keys().any(|e| e[index] > 0)
    }

    fn accumulate(&mut self, exponents: Exponents, value: Rational) -> Exact<()> {
        if value.is_zero() {
            return Ok(());
        }
        let sum = match self.terms.get(&exponents) {
            Some(old) => old.add(value)?,
            None => value,
        };
        if sum.is_zero() {
            self.terms.remove(&exponents);
        } else {
            self.terms.insert(exponents, sum);
        }
        Ok(())
    }

    /// `self + other`.
    pub fn add(&self, other: &Polynomial) -> Exact<Polynomial> {
        let mut sum = self.clone();
        for (e, c) in other.terms() {
            sum.accumulate(e.clone(), c)?;
        }
        Ok(sum)
    }

    /// `-self`.
    pub fn neg(&self) -> Exact<Polynomial> {
        self.scale(Rational::integer(-1))
    }

    /// `self - other`.
    pub fn sub(&self, other: &Polynomial) -> Exact<Polynomial> {
        self.add(&other.neg()?)
    }

    /// `factor * self`.
    pub fn scale(&self, factor: Rational) -> Exact<Polynomial> {
        let mut out = Polynomial::zero(self.nvars);
        if factor.is_zero() {
            return Ok(out);
        }
        for (e, c) in self.terms() {
            out.terms.insert(e.clone(), c.mul(factor)?);
        }
        Ok(out)
    }

    /// `self * other`.
    pub fn mul(&self, other: &Polynomial) -> Exact<Polynomial> {
        let mut out = Polynomial::zero(self.nvars);
        for (a, ca) in self.terms() {
            for (b, cb) in other.terms() {
                let e: Exponents = a.iter().zip(b).map(|(x, y)| x + y).collect();
                out.accumulate(e, ca.mul(cb)?)?;
            }
        }
        Ok(out)
    }

    /// `self^exponent` (`self^0 = 1`).
    pub fn pow(&self, exponent: u32) -> Exact<Polynomial> {
        let mut out = Polynomial::constant(self.nvars, Rational::ONE);
        for _ in 0..exponent {
            out = out.mul(self)?;
        }
        Ok(out)
    }

    /// ∂self/∂x_index.
    pub fn derivative(&self, index: usize) -> Exact<Polynomial> {
        let mut out = Polynomial::zero(self.nvars);
        for (e, c) in self.terms() {
            let k = e[index];
            if k == 0 {
                continue;
            }
            let mut lowered = e.clone();
            lowered[index] -= 1;
            out.accumulate(lowered, c.mul(Rational::integer(i128::from(k)))?)?;
        }
        Ok(out)
    }

    /// Value at `x` (`x.len() == nvars`), exactly.
    pub fn value_at(&self, x: &[Rational]) -> Exact<Rational> {
        self.terms().try_fold(Rational::ZERO, |sum, (e, c)| {
            let term = e
                .iter()
                .zip(x)
                .try_fold(c, |product, (&k, &v)| product.mul(v.pow(k)?))?;
            sum.add(term)
        })
    }

    /// Value at `x` (`x.len() == nvars`), in floating point.
    #[cfg(test)]
    pub fn evaluate(&self, x: &[f64]) -> f64 {
        self.terms()
            .map(|(e, c)| {
                e.iter()
                    .zip(x)
                    .fold(c.to_f64(), |acc, (&k, &xi)| acc * xi.powi(k as i32))
            })
            .sum()
    }

    /// Human-readable form with the given variable names, in DSL syntax
    /// (`0.5*p^2 + q`), terms ordered by degree then graded-lex.
    pub fn display<'a>(&'a self, names: &'a [String]) -> PolynomialDisplay<'a> {
        PolynomialDisplay {
            poly: self,
            names,
            limit: usize::MAX,
        }
    }

    /// As [`display`](Self::display), but only the first `limit` terms (in
    /// graded order) and a count of the others: for error messages, which
    /// must stay readable when the polynomial has thousands of terms.
    pub fn display_at_most<'a>(
        &'a self,
        names: &'a [String],
        limit: usize,
    ) -> PolynomialDisplay<'a> {
        PolynomialDisplay {
            poly: self,
            names,
            limit,
        }
    }
}

/// See [`Polynomial::display`].
pub struct PolynomialDisplay<'a> {
    poly: &'a Polynomial,
    names: &'a [String],
    limit: usize,
}

impl fmt::Display for PolynomialDisplay<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.poly.is_zero() {
            return f.write_str("0");
        }
        let mut terms: Vec<_> = self.poly.terms().collect();
        terms.sort_by(|(a, _), (b, _)| crate::bases::graded_lex_cmp(a, b));
        let hidden = terms.len().saturating_sub(self.limit);
        for (i, (e, c)) in terms.iter().take(self.limit).enumerate() {
            let negative = c.numerator() < 0;
            let magnitude = if negative {
                Rational::new(-c.numerator(), c.denominator())
                    .ok()
                    .flatten()
                    .unwrap_or(*c)
            } else {
                *c
            };
            match (i, negative) {
                (0, true) => f.write_str("-")?,
                (0, false) => {}
                (_, true) => f.write_str(" - ")?,
                (_, false) => f.write_str(" + ")?,
            }
            let factors: Vec<String> = e
                .iter()
                .zip(self.names)
                .filter(|(k, _)| **k > 0)
                .map(|(k, name)| {
                    if *k == 1 {
                        name.clone()
                    } else {
                        format!("{name}^{k}")
                    }
                })
                .collect();
            if factors.is_empty() {
                write!(f, "{magnitude}")?;
            } else if magnitude == Rational::ONE {
                f.write_str(&factors.join("*"))?;
            } else {
                write!(f, "{magnitude}*{}", factors.join("*"))?;
            }
        }
        if hidden > 0 {
            write!(f, " + … ({hidden} more terms)")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn r(n: i128, d: i128) -> Rational {
        Rational::new(n, d).unwrap().unwrap()
    }

    #[test]
    fn rationals_are_normalised() {
        assert_eq!(r(2, 4), r(1, 2));
        assert_eq!(r(3, -6), r(-1, 2));
        assert_eq!(r(-3, -6).denominator(), 2);
        assert_eq!(Rational::new(1, 0).unwrap(), None);
    }

    /// Decimals of up to 37 digits come out as the nearest f64, as Rust's
    /// own (correctly rounded) parser gives them.
    #[test]
    fn decimals_round_to_the_nearest_f64() {
        let cases: [(i128, u32); 5] = [
            (1_602_176_634, 28),
            (30_000_000_000_000_000_000_001, 23),
            (12_345_678_901_234_567_890_123, 23),
            (9_007_199_254_740_993, 0), // 2⁵³ + 1: a tie, to even
            (99_999_999_999_999_999_999_999_999_999_999_999, 37),
        ];
        for (digits, places) in cases {
            let value = r(digits, 10_i128.pow(places)).to_f64();
            let expected: f64 = format!("{digits}e-{places}").parse().unwrap();
            assert_eq!(value, expected, "{digits}e-{places}");
            assert_eq!(r(-digits, 10_i128.pow(places)).to_f64(), -expected);
        }
        assert_eq!(r(1, 3).to_f64(), 1.0 / 3.0);
        assert_eq!(r(i128::MAX, 1).to_f64(), 2f64.powi(127));
        assert_eq!(r(1, i128::MAX).to_f64(), 1.0 / 2f64.powi(127));
        assert_eq!(Rational::ZERO.to_f64(), 0.0);
    }

    proptest! {
        #[test]
        fn every_decimal_rounds_to_the_nearest_f64(
            digits in 1_i128..10_i128.pow(37),
            places in 0_u32..38,
            scale_up in any::<bool>(),
        ) {
            let (rational, text) = if scale_up && digits.checked_mul(10_i128.pow(places)).is_some() {
                (r(digits * 10_i128.pow(places), 1), format!("{digits}e{places}"))
            } else {
                (r(digits, 10_i128.pow(places)), format!("{digits}e-{places}"))
            };
            prop_assert_eq!(rational.to_f64(), text.parse::<f64>().unwrap());
        }
    }

    #[test]
    fn rational_arithmetic() {
        assert_eq!(r(1, 2).add(r(1, 3)).unwrap(), r(5, 6));
        assert_eq!(r(1, 2).sub(r(1, 3)).unwrap(), r(1, 6));
        assert_eq!(r(2, 3).mul(r(9, 4)).unwrap(), r(3, 2));
        assert_eq!(r(2, 3).div(r(4, 9)).unwrap(), Some(r(3, 2)));
        assert_eq!(r(2, 3).div(Rational::ZERO).unwrap(), None);
        assert_eq!(r(-2, 3).pow(3).unwrap(), r(-8, 27));
    }

    #[test]
    fn rational_overflow_is_reported() {
        let big = Rational::integer(i128::MAX / 2 + 1);
        assert_eq!(big.add(big), Err(Overflow));
        assert_eq!(big.mul(Rational::integer(3)), Err(Overflow));
        assert_eq!(Rational::integer(10).pow(40), Err(Overflow));
        assert_eq!(Rational::new(i128::MIN, 1), Err(Overflow));
    }

    #[test]
    fn decimal_literals_are_exact() {
        let p = |s| Rational::parse_decimal(s).unwrap().unwrap();
        assert_eq!(p("12"), Rational::integer(12));
        assert_eq!(p("0.1"), r(1, 10));
        assert_eq!(p("2.5e-3"), r(1, 400));
        assert_eq!(p("1E+2"), Rational::integer(100));
        assert_eq!(p("1."), Rational::ONE);
        assert_eq!(Rational::parse_decimal("1x").unwrap(), None);
        assert_eq!(Rational::parse_decimal("1e400"), Err(DecimalRange::Large));
        assert_eq!(
            Rational::parse_decimal("1.5e-9223372036854775808"),
            Err(DecimalRange::Small { places: None })
        );
        assert_eq!(
            Rational::parse_decimal("1e-400"),
            Err(DecimalRange::Small { places: Some(400) })
        );
        // Well above 1e-38, but 43 places.
        assert_eq!(
            Rational::parse_decimal("1.054571817e-34"),
            Err(DecimalRange::Small { places: Some(43) })
        );
        let digits = format!("1.{}1", "0".repeat(40));
        assert_eq!(Rational::parse_decimal(&digits), Err(DecimalRange::Digits));
        let large = format!("1{}1", "0".repeat(40));
        assert_eq!(Rational::parse_decimal(&large), Err(DecimalRange::Large));
        // Zeros are not digits to carry: these are small, or zero, and
        // representable.
        assert_eq!(p("0e400"), Rational::ZERO);
        assert_eq!(p("0.000"), Rational::ZERO);
        let long_one = format!("1.{}", "0".repeat(60));
        assert_eq!(p(&long_one), Rational::ONE);
        let quarter = format!("25{}e-60", "0".repeat(58));
        assert_eq!(p(&quarter), r(1, 4));
        assert_eq!(p("1000e-3"), Rational::ONE);
        assert_eq!(p("0.0025"), r(1, 400));
        // …but a denominator of 10³⁹ is not.
        assert_eq!(
            Rational::parse_decimal("1e-39"),
            Err(DecimalRange::Small { places: Some(39) })
        );
    }

    #[test]
    fn rationals_display_as_decimals_when_they_terminate() {
        assert_eq!(r(1, 2).to_string(), "0.5");
        assert_eq!(r(-1, 8).to_string(), "-0.125");
        assert_eq!(r(3, 20).to_string(), "0.15");
        assert_eq!(r(1, 3).to_string(), "1/3");
        assert_eq!(Rational::integer(-7).to_string(), "-7");
    }

    #[test]
    fn polynomial_display_uses_dsl_syntax() {
        let names = vec!["q".to_string(), "p".to_string()];
        let q = Polynomial::variable(2, 0);
        let p = Polynomial::variable(2, 1);
        let poly = q
            .pow(2)
            .unwrap()
            .scale(r(1, 2))
            .unwrap()
            .sub(&p)
            .unwrap()
            .add(&Polynomial::constant(2, Rational::integer(3)))
            .unwrap();
        assert_eq!(poly.display(&names).to_string(), "3 - p + 0.5*q^2");
    }

    fn small_rational() -> impl Strategy<Value = Rational> {
        (-20i128..=20, 1i128..=6).prop_map(|(n, d)| r(n, d))
    }

    proptest! {
        #[test]
        fn rational_field_laws(a in small_rational(), b in small_rational(), c in small_rational()) {
            prop_assert_eq!(a.add(b).unwrap(), b.add(a).unwrap());
            prop_assert_eq!(a.mul(b.add(c).unwrap()).unwrap(), a.mul(b).unwrap().add(a.mul(c).unwrap()).unwrap());
            prop_assert_eq!(a.sub(a).unwrap(), Rational::ZERO);
            if !b.is_zero() {
                prop_assert_eq!(a.div(b).unwrap().unwrap().mul(b).unwrap(), a);
            }
            prop_assert!((a.add(b).unwrap().to_f64() - (a.to_f64() + b.to_f64())).abs() < 1e-12);
        }
    }
}
