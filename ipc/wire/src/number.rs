//! Numbers as an operator types them, for every frontend: digits with one decimal point or
//! one decimal comma (`94.94`, `94,94`), an optional sign, nothing else. A shop in Germany
//! types the comma, a keypad may give either; both mean the same. What is refused says so in
//! the operator's words with the field's name: a thousands separator (`1.234,5`, `1,234.5`),
//! two separators, an exponent, letters, an empty field. The values themselves (ranges,
//! limits) are the loop's or the set-up code's to check.

use crate::Error;

/// The number in `text`, or `None` when it is not one by the rule above.
pub fn decimal(text: &str) -> Option<f64> {
    let t = text.trim();
    let body = t.strip_prefix(['+', '-']).unwrap_or(t);
    let mut separators = body.char_indices().filter(|(_, c)| *c == '.' || *c == ',');
    let sep = separators.next();
    if separators.next().is_some() {
        return None;
    }
    let (int, frac) = match sep {
        Some((i, c)) => (&body[..i], &body[i + c.len_utf8()..]),
        None => (body, ""),
    };
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if int.len() + frac.len() == 0 || !digits(int) || !digits(frac) {
        return None;
    }
    let canonical = format!("{}{int}.{frac}", if t.starts_with('-') { "-" } else { "" });
    canonical.parse::<f64>().ok().filter(|x| x.is_finite())
}

/// [`decimal`] of the field named `field`, refused in words.
pub fn parse(field: &str, text: &str) -> Result<f64, Error> {
    decimal(text).ok_or_else(|| Error::NotANumber {
        field: field.to_string(),
        text: text.trim().to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_point_or_a_comma_is_the_decimal_separator() {
        for (t, x) in [
            ("94.94", 94.94),
            ("94,94", 94.94),
            (" -3,5 ", -3.5),
            ("+120", 120.0),
            (",5", 0.5),
            ("7.", 7.0),
            ("0", 0.0),
        ] {
            assert_eq!(decimal(t), Some(x), "{t}");
        }
    }

    #[test]
    fn anything_else_is_refused_with_the_fields_name() {
        for t in [
            "", " ", ",", "-", "1.234,5", "1,234.5", "1,2,3", "1e3", "inf", "NaN", "94,94 mm", "--1", "0x10",
            "٣",
        ] {
            assert_eq!(decimal(t), None, "{t}");
        }
        let e = parse("X gauge diameter", "1.234,5").unwrap_err();
        assert_eq!(
            e.to_string(),
            "X gauge diameter: \"1.234,5\" is not a number (digits with one decimal point or comma: 94.94 or 94,94)"
        );
    }

    proptest! {
        /// Any number written with a point reads back the same with a comma in its place.
        #[test]
        fn comma_and_point_read_alike(x in -1.0e6f64..1.0e6, digits in 0usize..6) {
            let pointed = format!("{x:.digits$}");
            let commaed = pointed.replace('.', ",");
            prop_assert_eq!(decimal(&pointed), pointed.parse::<f64>().ok());
            prop_assert_eq!(decimal(&commaed), decimal(&pointed));
        }
    }
}
