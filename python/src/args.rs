//! Scalar arguments as they come: every whole-number, string and number argument of the bindings
//! is taken as a [`Whole`], [`Text`] or [`Number`], whose extraction never fails, and converted
//! with a `ValueError` naming the argument (issue 30). Typed pyo3 arguments raised pyo3's
//! `TypeError` for a wrong type and `OverflowError` for an integer of 2**127 or more, where the
//! documentation promises a `ValueError` naming the argument.

use crate::arrays::describe;
use crate::value_error;
use pyo3::prelude::*;
use pyo3::types::PyBool;

/// A whole-number argument (`n`, `seed`, `trial`, `threads`, `kernel_mean_samples`): a Python
/// int (or anything with `__index__`, as a numpy integer), of any size; a bool is no number here.
pub struct Whole(Result<i128, String>);

impl Whole {
    /// A default value.
    pub const fn of(v: i128) -> Whole {
        Whole(Ok(v))
    }

    /// The value as a `u64`: `name: must be a whole number from 0 to 18446744073709551615, got …`
    /// for anything else (a negative or huge int, a float, a string).
    pub fn get(&self, name: &str) -> PyResult<u64> {
        match &self.0 {
            Ok(v) => u64::try_from(*v).map_err(|_| out_of_range(name, u64::MAX as u128, &v.to_string())),
            Err(shown) => Err(out_of_range(name, u64::MAX as u128, shown)),
        }
    }

    /// The int given, if it is one (of any size).
    pub fn int(&self) -> Option<i128> {
        self.0.as_ref().ok().copied()
    }

    /// The value as a `usize`.
    pub fn count(&self, name: &str) -> PyResult<usize> {
        match &self.0 {
            Ok(v) => usize::try_from(*v).map_err(|_| out_of_range(name, usize::MAX as u128, &v.to_string())),
            Err(shown) => Err(out_of_range(name, usize::MAX as u128, shown)),
        }
    }
}

fn out_of_range(name: &str, max: u128, shown: &str) -> PyErr {
    value_error(format!(
        "{name}: must be a whole number from 0 to {max}, got {shown}"
    ))
}

impl<'a, 'py> FromPyObject<'a, 'py> for Whole {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let obj = obj.to_owned();
        if obj.is_instance_of::<PyBool>() {
            return Ok(Whole(Err(describe(&obj))));
        }
        Ok(Whole(match obj.extract::<i128>() {
            Ok(v) => Ok(v),
            // An int beyond i128 (OverflowError): its digits; anything else: what it is.
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => Err(obj
                .repr()
                .map_or_else(|_| describe(&obj), |r| shorten(&r.to_string()))),
            Err(_) => Err(describe(&obj)),
        }))
    }
}

/// A string argument (`design`, `method`, `scale`, `density`, `kernel_mean`).
pub struct Text(Result<String, String>);

impl Text {
    /// A default value.
    pub fn of(s: &str) -> Text {
        Text(Ok(s.to_string()))
    }

    /// The string, or `name: must be a string, got …`.
    pub fn get(&self, name: &str) -> PyResult<&str> {
        match &self.0 {
            Ok(s) => Ok(s),
            Err(shown) => Err(value_error(format!("{name}: must be a string, got {shown}"))),
        }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for Text {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let obj = obj.to_owned();
        Ok(Text(obj.extract::<String>().map_err(|_| describe(&obj))))
    }
}

/// A real-number argument (`noise`, `prior`): a Python float or int (or anything with
/// `__float__`, as a numpy float); a bool is no number here.
pub struct Number(Result<f64, String>);

impl Number {
    /// The number (range checks are the caller's), or `name: must be a number, got …`.
    pub fn get(&self, name: &str) -> PyResult<f64> {
        match &self.0 {
            Ok(v) => Ok(*v),
            Err(shown) => Err(value_error(format!("{name}: must be a number, got {shown}"))),
        }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for Number {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let obj = obj.to_owned();
        if obj.is_instance_of::<PyBool>() {
            return Ok(Number(Err(describe(&obj))));
        }
        Ok(Number(match obj.extract::<f64>() {
            Ok(v) => Ok(v),
            // An int too large for a float (OverflowError): its digits, shortened.
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => Err(obj
                .repr()
                .map_or_else(|_| describe(&obj), |r| shorten(&r.to_string()))),
            Err(_) => Err(describe(&obj)),
        }))
    }
}

/// A long run of digits as its first ones and its length.
fn shorten(digits: &str) -> String {
    if digits.len() > 24 {
        format!(
            "{}… ({} digits)",
            &digits[..12],
            digits.trim_start_matches('-').len()
        )
    } else {
        digits.to_string()
    }
}

/// [`Whole::get`] of an optional argument.
pub fn whole_opt(v: Option<&Whole>, name: &str) -> PyResult<Option<u64>> {
    v.map(|v| v.get(name)).transpose()
}

/// [`Text::get`] of an optional argument.
pub fn text_opt<'a>(v: Option<&'a Text>, name: &str) -> PyResult<Option<&'a str>> {
    v.map(|v| v.get(name)).transpose()
}

/// [`Number::get`] of an optional argument.
pub fn number_opt(v: Option<&Number>, name: &str) -> PyResult<Option<f64>> {
    v.map(|v| v.get(name)).transpose()
}
