//! Numbers in messages: as written (`0.6`, `-1`, `2.000001`) between 1e-4 and 1e16, in exponent
//! form outside (`-1e-300`, `1e308`), never three hundred digits (issue 30: `s: 1e308` printed
//! 309 of them).

/// `v` for a message (see the module documentation).
pub fn shown(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e16).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::shown;

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(shown(2.0), "2");
        assert_eq!(shown(-0.8), "-0.8");
        assert_eq!(shown(1e308), "1e308");
        assert_eq!(shown(-1e-300), "-1e-300");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(shown(2.000001), "2.000001");
    }
}
