//! Reading the JSON spec files (experiments, render tables): one parser, one error form.
//!
//! Errors read `path: message`, with the JSON path in the form `estimators[2].kernel` (the
//! file name is added by the caller), so every spec reports bad input the same way.
//!
//! Beyond what serde_json checks, [`parse`] accepts a UTF-8 byte-order mark (editors on
//! Windows write one), rejects duplicate keys (serde_json would silently keep the last value,
//! so a file could say one thing and run another), and explains the errors a user can make
//! (an empty file, `NaN`, numbers that do not fit a whole-number field) in one line each.

use crate::error::InputError;
use crate::files::read::FileKind;
use serde::de::{self, DeserializeOwned, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};
use std::cell::RefCell;
use std::fmt::Write as _;
use std::path::Path;

/// Largest spec file read: real specs are a few kilobytes, and reading a file the user named
/// by mistake (a gigabyte of data) must not exhaust memory.
pub const MAX_SPEC_BYTES: u64 = FileKind::Spec.limit();

/// Reads the spec file at `path` for [`parse`] through [`crate::files::read`]: a regular file
/// of at most [`MAX_SPEC_BYTES`], UTF-8.
///
/// Errors name the file: unreadable files, folders, pipes and devices, files over the limit, and
/// bytes that are not UTF-8 (with their line and column).
pub fn read_spec(path: &Path) -> Result<String, InputError> {
    crate::files::read::read_text(path, FileKind::Spec).map_err(|e| InputError::new(e.to_string()))
}

/// The UTF-8 byte-order mark, which some editors put at the start of a file.
const BOM: char = '\u{feff}';

/// Parses `text` as the spec type `T` (which should be `deny_unknown_fields`); `what` names the
/// kind of file for a message about the top-level value ("the experiment").
pub fn parse<T: DeserializeOwned>(text: &str, what: &str) -> Result<T, String> {
    let text = text.strip_prefix(BOM).unwrap_or(text);
    if text.trim_matches(is_json_whitespace).is_empty() {
        return Err(format!(
            "the file is empty; it must hold one JSON object ({what})"
        ));
    }
    let value = parse_value(text)?;
    if !value.is_object() {
        return Err(format!(
            "the file must hold one JSON object ({what}), got {}",
            kind(&value)
        ));
    }
    from_value(value)
}

/// `value` as `T`, with an error `path: message` naming the innermost field that failed
/// (`axis[1]: invalid type: …`): what a hand-written `Deserialize` that reads a [`Value`] first
/// (to say which forms a field accepts) uses for the object inside, so that the path goes on
/// past it (`integrands[0].brdf.axis[1]`, not `integrands[0]`; issue 42).
pub fn from_value<T: DeserializeOwned>(value: Value) -> Result<T, String> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let inner = explain_type_error(&e.into_inner().to_string());
        if path == "." { inner } else { at(&path, &inner) }
    })
}

/// `path: message`, the one form of a spec error, where a message that starts with a field path
/// of its own (`brdf.phong: must be …`, `normal[0]: invalid type …`, from the value inside)
/// continues `path` instead: `integrands[0].brdf.phong: must be …`. Every spec reader builds its
/// paths with it, so a sub-field is named however deep it is.
pub fn at(path: &str, message: &str) -> String {
    match message.split_once(": ") {
        Some((sub, rest)) if is_field_path(sub) => {
            let dot = if sub.starts_with('[') { "" } else { "." };
            format!("{path}{dot}{sub}: {rest}")
        }
        _ => format!("{path}: {message}"),
    }
}

/// The sample counts N of a spec's list `field` (an experiment's `samples`, an irradiance file's
/// `n`): at least one, each at least 1, none listed twice — one check for every kind of file, so
/// that `[4, 4]` is refused by all of them (issue 42: irradiance files took it silently).
pub fn check_counts(field: &str, counts: &[u64]) -> Result<(), String> {
    if counts.is_empty() {
        return Err(format!("{field}: must list at least one sample count"));
    }
    for (i, &n) in counts.iter().enumerate() {
        if n == 0 {
            return Err(format!("{field}[{i}]: N must be at least 1, got 0"));
        }
        if counts[..i].contains(&n) {
            return Err(format!("{field}[{i}]: N = {n} is listed twice"));
        }
    }
    Ok(())
}

/// Whether `s` is a JSON field path as the messages write it: keys (letters, digits, `_`, `$`,
/// not starting with a digit, so that a value such as `100: applies to …` is not taken for one)
/// joined by `.`, each optionally followed by indices `[3]`, or indices alone (`[1]`).
fn is_field_path(s: &str) -> bool {
    let key = |k: &str| {
        let name_end = k.find('[').unwrap_or(k.len());
        let (name, mut indices) = k.split_at(name_end);
        let name_ok = name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '$'))
            && !name.starts_with(|c: char| c.is_ascii_digit());
        while let Some(rest) = indices.strip_prefix('[') {
            let Some((digits, after)) = rest.split_once(']') else {
                return false;
            };
            if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
                return false;
            }
            indices = after;
        }
        name_ok && indices.is_empty() && !k.is_empty()
    };
    !s.is_empty() && s.split('.').all(key)
}

fn is_json_whitespace(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\r')
}

/// `an array`, `a string`, … for messages.
pub fn kind(value: &serde_json::Value) -> &'static str {
    match value {
        serde_json::Value::Object(_) => "an object",
        serde_json::Value::Array(_) => "an array",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Null => "null",
    }
}

/// Which kind of spec a file holds, from its top-level keys: render tables have `variants`,
/// irradiance files a `"kind"` (`"irradiance"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecKind {
    Experiment,
    RenderTable,
    Irradiance,
}

/// The kind of spec in `text`, if it is a JSON object with `estimators` or `variants`.
pub fn spec_kind(text: &str) -> Option<SpecKind> {
    let text = text.strip_prefix(BOM).unwrap_or(text);
    let value: serde_json::Value = serde_json::from_str(text).ok()?;
    let obj = value.as_object()?;
    // Only irradiance files have a `kind`: any `kind` makes the file one, so that a misspelt
    // one (`"irradiance2"`) gets the irradiance reader's message naming `kind` and its value,
    // not an experiment's about fields it lacks (issue 42).
    if obj.contains_key("kind") {
        return Some(SpecKind::Irradiance);
    }
    if obj.contains_key("variants") && !obj.contains_key("estimators") {
        Some(SpecKind::RenderTable)
    } else {
        Some(SpecKind::Experiment)
    }
}

/// For a number that does not fit a `u64` field, serde says only "invalid type: floating point"
/// or "invalid value: integer": say instead what the file may hold and why the number is not it
/// (too big, negative, not whole). Other messages are returned unchanged.
fn explain_type_error(message: &str) -> String {
    const WHOLE: &str = "expected a whole number from 0 to 18446744073709551615";
    let Some(got) = message.strip_suffix(", expected u64").and_then(|m| {
        m.strip_prefix("invalid type: ")
            .or_else(|| m.strip_prefix("invalid value: "))
    }) else {
        return message.to_string();
    };
    let number = got
        .strip_prefix("floating point `")
        .or_else(|| got.strip_prefix("integer `"))
        .and_then(|n| n.strip_suffix('`'));
    match number.map(|n| (n, n.parse::<f64>())) {
        Some((n, Ok(v))) if v < 0.0 => format!("{WHOLE}, got {n}, which is negative"),
        // 2^64 is the first float above u64::MAX.
        Some((n, Ok(v))) if v >= 18_446_744_073_709_551_616.0 => {
            format!("{WHOLE}, got {n}, which is too big")
        }
        Some((n, Ok(v))) if v.fract() != 0.0 => format!("{WHOLE}, got {n}, which is not whole"),
        Some((n, Ok(_))) => {
            format!("{WHOLE}, got {n} written with a decimal point or exponent; write it as a plain integer")
        }
        // Strings, booleans, …: serde's "invalid type: string \"7\"" already says what is wrong.
        _ => message.to_string(),
    }
}

/// Parses JSON text into a [`Value`], rejecting duplicate keys, with errors `path: message`.
fn parse_value(text: &str) -> Result<Value, String> {
    let tracker = Tracker::default();
    let mut de = serde_json::Deserializer::from_str(text);
    let result = ValueSeed(&tracker)
        .deserialize(&mut de)
        .and_then(|v| de.end().map(|()| v));
    result.map_err(|e| {
        if let Some(duplicate) = tracker.duplicate.take() {
            return format!("{duplicate} at line {} column {}", e.line(), e.column());
        }
        syntax_message(text, &e, tracker.failed_at.take())
    })
}

/// Where the parse is (the JSON path), and what went wrong where.
#[derive(Default)]
struct Tracker {
    path: RefCell<Vec<Segment>>,
    /// The path of the innermost value that failed to parse (set once, by the innermost).
    failed_at: RefCell<Option<String>>,
    /// `path: duplicate key "k"`, when that is why parsing stopped.
    duplicate: RefCell<Option<String>>,
}

enum Segment {
    Key(String),
    Index(usize),
}

impl Tracker {
    /// The current path, written like serde_path_to_error's (`estimators[1].noise`, `.` at the
    /// top), so both kinds of error point the same way.
    fn path(&self) -> String {
        let path = self.path.borrow();
        if path.is_empty() {
            return ".".into();
        }
        let mut s = String::new();
        for (i, segment) in path.iter().enumerate() {
            match segment {
                Segment::Key(k) if i == 0 => s += k,
                Segment::Key(k) => {
                    let _ = write!(s, ".{k}");
                }
                Segment::Index(j) => {
                    let _ = write!(s, "[{j}]");
                }
            }
        }
        s
    }

    /// Runs `parse` with `segment` pushed on the path, noting the path if it fails first here.
    fn within<T, E>(&self, segment: Segment, parse: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        self.path.borrow_mut().push(segment);
        let result = parse();
        if result.is_err() && self.failed_at.borrow().is_none() {
            *self.failed_at.borrow_mut() = Some(self.path());
        }
        self.path.borrow_mut().pop();
        result
    }
}

/// Deserializes one JSON value into a [`Value`], tracking the path and rejecting duplicate
/// keys (serde_json's own `Value` keeps the last of them silently).
struct ValueSeed<'a>(&'a Tracker);

impl<'de> DeserializeSeed<'de> for ValueSeed<'_> {
    type Value = Value;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for ValueSeed<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Value, E> {
        // serde_json reads only finite numbers from text; this is a guard, not a path taken.
        serde_json::Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| E::custom(format!("{v} is not a finite number")))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = self.0.within(Segment::Index(items.len()), || {
            seq.next_element_seed(ValueSeed(self.0))
        })? {
            items.push(item);
        }
        Ok(Value::Array(items))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut object = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            let tracker = self.0;
            let duplicate = object.contains_key(&key);
            let value = tracker.within(Segment::Key(key.clone()), || {
                if duplicate {
                    *tracker.duplicate.borrow_mut() =
                        Some(format!("{}: duplicate key {key:?}", tracker.path()));
                    return Err(de::Error::custom("duplicate key"));
                }
                map.next_value_seed(ValueSeed(tracker))
            })?;
            object.insert(key, value);
        }
        Ok(Value::Object(object))
    }
}

/// A syntax error in one line: where (JSON path, line and column), what serde_json expected,
/// the text found there, and a hint for the mistakes people make (`NaN`, `Infinity`).
fn syntax_message(text: &str, e: &serde_json::Error, path: Option<String>) -> String {
    let (line, column) = (e.line(), e.column());
    let full = e.to_string();
    let what = full
        .strip_suffix(&format!(" at line {line} column {column}"))
        .unwrap_or(&full);
    if what == "recursion limit exceeded" {
        // The path would be a hundred `[0]`s; the position says enough.
        return format!(
            "malformed JSON at line {line} column {column}: nested more than 127 arrays and objects deep"
        );
    }
    // "malformed JSON" first, so the message says at once that the file is not JSON at all.
    let within = match path {
        Some(p) if p != "." => format!(" in {p}"),
        _ => String::new(),
    };
    let mut message = format!("malformed JSON{within} at line {line} column {column}: {what}");
    if let Some(token) = token_at(text, line, column) {
        let _ = write!(message, ", found `{token}`");
        let bare = token.trim_start_matches(['-', '+']).to_ascii_lowercase();
        if ["nan", "infinity", "inf"].contains(&bare.as_str()) {
            message += " (JSON has no NaN or Infinity: numbers must be finite)";
        }
    }
    message
}

/// The word (letters, digits, `.`, `+`, `-`) around the 1-based byte `column` of `line`, at
/// most 40 characters; `None` at the end of the text or on punctuation.
fn token_at(text: &str, line: usize, column: usize) -> Option<String> {
    let row = text.split('\n').nth(line.checked_sub(1)?)?;
    let at = column.checked_sub(1)?;
    let is_word = |c: char| c.is_alphanumeric() || matches!(c, '.' | '+' | '-' | '_');
    if at >= row.len() || !row.is_char_boundary(at) || !row[at..].starts_with(is_word) {
        return None;
    }
    let start = row[..at]
        .rfind(|c: char| !is_word(c))
        .map_or(0, |p| p + row[p..].chars().next().map_or(1, char::len_utf8));
    let end = row[at..]
        .find(|c: char| !is_word(c))
        .map_or(row.len(), |p| at + p);
    let token: String = row[start..end].chars().take(40).collect();
    Some(token)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Spec {
        seed: u64,
        #[serde(default)]
        items: Vec<Item>,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Item {
        noise: f64,
    }

    fn error(text: &str) -> String {
        parse::<Spec>(text, "the spec").unwrap_err()
    }

    /// Issue 42: a message that names a sub-field continues the path (`brdf.phong`,
    /// `normal[0]`) instead of standing after it.
    #[test]
    fn sub_fields_continue_the_path() {
        assert_eq!(
            at("integrands[0]", "brdf.phong: must be in (0, 1e6]"),
            "integrands[0].brdf.phong: must be in (0, 1e6]"
        );
        assert_eq!(
            at("integrands[0]", "normal[0]: invalid type"),
            "integrands[0].normal[0]: invalid type"
        );
        assert_eq!(
            at("integrands[0].brdf", "axis[1]: invalid type"),
            "integrands[0].brdf.axis[1]: invalid type"
        );
        assert_eq!(at("n", "[1]: listed twice"), "n[1]: listed twice");
        // Prose is not a path: it stands after the path as before.
        assert_eq!(
            at("estimators[2].kernel", "sobolev kernel: s must be"),
            "estimators[2].kernel: sobolev kernel: s must be"
        );
        assert_eq!(
            at("samples[1]", "N must be at least 1, got 0"),
            "samples[1]: N must be at least 1, got 0"
        );
        assert_eq!(at("x", "a[b]: c"), "x: a[b]: c");
        // A value is not a path, nor is a number.
        assert_eq!(
            at("reference.spp", "100: applies to"),
            "reference.spp: 100: applies to"
        );
        assert_eq!(at("x", "0.5: too small"), "x: 0.5: too small");
    }

    #[test]
    fn duplicate_keys_are_rejected_with_their_path() {
        assert_eq!(
            error("{\"seed\": 1, \"seed\": 2}"),
            "seed: duplicate key \"seed\" at line 1 column 18"
        );
        let e = error("{\"seed\": 1, \"items\": [{\"noise\": 1}, {\"noise\": 1,\n \"noise\": 2}]}");
        assert!(
            e.starts_with("items[1].noise: duplicate key \"noise\" at line 2"),
            "{e}"
        );
        // The same key in different objects is fine.
        parse::<Spec>("{\"seed\": 1, \"items\": [{\"noise\": 1}, {\"noise\": 2}]}", "x").unwrap();
    }

    #[test]
    fn a_byte_order_mark_is_accepted() {
        let spec: Spec = parse("\u{feff}{\"seed\": 3}", "the spec").unwrap();
        assert_eq!(spec.seed, 3);
        assert_eq!(
            spec_kind("\u{feff}{\"variants\": []}"),
            Some(SpecKind::RenderTable)
        );
    }

    #[test]
    fn empty_and_non_object_files_say_what_is_expected() {
        for text in ["", " \n\t", "\u{feff}"] {
            assert_eq!(
                error(text),
                "the file is empty; it must hold one JSON object (the spec)"
            );
        }
        assert_eq!(
            error("[{\"seed\": 1}]"),
            "the file must hold one JSON object (the spec), got an array"
        );
    }

    #[test]
    fn non_finite_literals_are_named_with_their_path() {
        for (literal, column) in [("NaN", 33), ("Infinity", 33), ("-Infinity", 34)] {
            let e = error(&format!("{{\"seed\": 1, \"items\": [{{\"noise\": {literal}}}]}}"));
            assert!(
                e.starts_with(&format!(
                    "malformed JSON in items[0].noise at line 1 column {column}: "
                )),
                "{e}"
            );
            assert!(
                e.contains(&format!("found `{literal}`"))
                    && e.ends_with("(JSON has no NaN or Infinity: numbers must be finite)"),
                "{e}"
            );
        }
    }

    #[test]
    fn numbers_that_do_not_fit_a_whole_number_field_say_why() {
        let whole = "seed: expected a whole number from 0 to 18446744073709551615, got";
        for (value, why) in [
            ("18446744073709551616", "which is too big"),
            ("1e30", "which is too big"),
            ("-1", "which is negative"),
            ("2.5", "which is not whole"),
            ("1e3", "written with a decimal point or exponent"),
        ] {
            let e = error(&format!("{{\"seed\": {value}}}"));
            assert!(e.starts_with(whole) && e.contains(why), "{value}: {e}");
        }
        assert_eq!(
            error("{\"seed\": \"7\"}"),
            "seed: invalid type: string \"7\", expected u64"
        );
        // The largest u64 itself is accepted.
        let spec: Spec = parse("{\"seed\": 18446744073709551615}", "x").unwrap();
        assert_eq!(spec.seed, u64::MAX);
        // Out of f64's range altogether: serde_json's message, with the path and the text.
        let e = error("{\"seed\": 1e400}");
        assert!(
            e.starts_with("malformed JSON in seed at line 1 column") && e.contains("`1e400`"),
            "{e}"
        );
    }

    #[test]
    fn deep_nesting_is_a_one_line_error() {
        let text = format!("{{\"seed\": {}{}}}", "[".repeat(200), "]".repeat(200));
        let e = error(&text);
        assert!(
            e.starts_with("malformed JSON at line 1 column 136: nested more than 127"),
            "{e}"
        );
    }

    #[test]
    fn syntax_errors_name_the_path_and_position() {
        assert_eq!(
            error("{\"seed\": 1, \"items\": [{\"noise\": 1} {}]}"),
            "malformed JSON in items[1] at line 1 column 36: expected `,` or `]`"
        );
        assert_eq!(
            error("{\"seed\": 1} x"),
            "malformed JSON at line 1 column 13: trailing characters, found `x`"
        );
        assert!(error("{\"seed\": ").starts_with("malformed JSON in seed at line 1 column 9: EOF"));
    }

    #[test]
    fn non_utf8_bytes_name_the_line_and_value() {
        use crate::files::read::utf8;
        assert_eq!(
            utf8(b"{\n  \"title\": \"a\xffb\"\n}".to_vec()).unwrap_err(),
            "line 2, column 14: byte 0xFF is not UTF-8 text; save the file as UTF-8"
        );
        assert_eq!(utf8("é\n".as_bytes().to_vec()).unwrap(), "é\n");
    }

    #[test]
    fn reading_is_bounded_and_refuses_folders() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(
            read_spec(dir.path()).unwrap_err().to_string(),
            format!("{}: is a folder, not a file", dir.path().display())
        );
        let big = dir.path().join("big.json");
        // Sparse: the test needs the size, not a gigabyte of disk.
        std::fs::File::create(&big).unwrap().set_len(1 << 30).unwrap();
        let e = read_spec(&big).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: the file is 1.0 GiB; spec files are limited to 16.0 MiB",
                big.display()
            )
        );
        std::fs::write(&big, "{}").unwrap();
        assert_eq!(read_spec(&big).unwrap(), "{}");
        let missing = read_spec(&dir.path().join("missing.json"))
            .unwrap_err()
            .to_string();
        assert!(missing.contains("missing.json: cannot read: "), "{missing}");
    }
}
