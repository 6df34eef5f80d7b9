//! What signac needs of a workspace: the project marker, and job ids that
//! are the MD5 of the state point as Python's `json.dumps(sp,
//! sort_keys=True)` writes it (so `signac.get_project(DIR)` opens the jobs
//! hardbody made).

use md5::{Digest, Md5};
use serde_json::Value;

/// `.signac/config` of a signac 2 project.
pub const PROJECT_CONFIG: &str = "schema_version = 2\n";

/// The job id of a state point: 32 hex digits.
pub fn job_id(statepoint: &Value) -> String {
    let text = python_json(statepoint);
    let digest = Md5::digest(text.as_bytes());
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// `value` as Python's `json.dumps(value, sort_keys=True)` writes it:
/// ", " and ": " separators, keys sorted, floats as `repr` gives them,
/// strings with ASCII escapes.
pub fn python_json(value: &Value) -> String {
    let mut out = String::new();
    write(value, &mut out);
    out
}

fn write(value: &Value, out: &mut String) {
    match value {
        Value::Null => out.push_str("null"),
        Value::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
        Value::Number(n) => match (n.as_i64(), n.as_u64(), n.as_f64()) {
            (Some(i), _, _) => out.push_str(&i.to_string()),
            (_, Some(u), _) => out.push_str(&u.to_string()),
            (_, _, Some(f)) => out.push_str(&python_float(f)),
            _ => out.push_str("null"),
        },
        Value::String(s) => string(s, out),
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                write(item, out);
            }
            out.push(']');
        }
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            out.push('{');
            for (i, key) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                string(key, out);
                out.push_str(": ");
                write(&map[key], out);
            }
            out.push('}');
        }
    }
}

fn string(s: &str, out: &mut String) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            c if (c as u32) < 0x20 || (c as u32) > 0x7e => {
                let mut units = [0u16; 2];
                for unit in c.encode_utf16(&mut units) {
                    out.push_str(&format!("\\u{unit:04x}"));
                }
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// A finite float as Python's `repr`: the shortest digits that read back
/// to it, fixed notation for decimal exponents from -4 to 15, else
/// `1.5e+20` with at least two exponent digits.
pub fn python_float(x: f64) -> String {
    if x == 0.0 {
        return if x.is_sign_negative() { "-0.0" } else { "0.0" }.into();
    }
    // Rust's `{:e}` gives the same shortest digits: `d.ddde±x`.
    let sci = format!("{:e}", x.abs());
    let (mantissa, exponent) = sci.split_once('e').expect("{:e} has an exponent");
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    let exponent: i32 = exponent.parse().expect("an integer exponent");
    let point = exponent + 1;
    let sign = if x < 0.0 { "-" } else { "" };
    let body = if (-3..=16).contains(&point) {
        let n = digits.len() as i32;
        if point <= 0 {
            format!("0.{}{digits}", "0".repeat((-point) as usize))
        } else if point >= n {
            format!("{digits}{}.0", "0".repeat((point - n) as usize))
        } else {
            let (a, b) = digits.split_at(point as usize);
            format!("{a}.{b}")
        }
    } else {
        let (first, rest) = digits.split_at(1);
        let fraction = if rest.is_empty() {
            String::new()
        } else {
            format!(".{rest}")
        };
        let e = point - 1;
        format!(
            "{first}{fraction}e{}{:02}",
            if e < 0 { '-' } else { '+' },
            e.abs()
        )
    };
    format!("{sign}{body}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_as_python_writes_them() {
        // repr() of each, from CPython 3.11.
        for (x, python) in [
            (2.0, "2.0"),
            (0.1, "0.1"),
            (1e-5, "1e-05"),
            (1e-4, "0.0001"),
            (1.5e-7, "1.5e-07"),
            (1e15, "1000000000000000.0"),
            (1e16, "1e+16"),
            (1.2345e22, "1.2345e+22"),
            (-3.25, "-3.25"),
            (123456.789, "123456.789"),
            (1.0 / 3.0, "0.3333333333333333"),
            (6.02214076e23, "6.02214076e+23"),
            (-0.0, "-0.0"),
        ] {
            assert_eq!(python_float(x), python, "{x:e}");
        }
    }

    #[test]
    fn job_ids_are_signacs() {
        // hashlib.md5(json.dumps(sp, sort_keys=True).encode()).hexdigest()
        // for sp = {"pressure": 2.0, "seed": 1, "x": 1e-05, "name": "a"},
        // as signac 2.4.1 names the job.
        let sp = serde_json::json!({"pressure": 2.0, "seed": 1, "x": 1e-05, "name": "a"});
        assert_eq!(
            python_json(&sp),
            r#"{"name": "a", "pressure": 2.0, "seed": 1, "x": 1e-05}"#
        );
        assert_eq!(job_id(&sp), "1a8f5ffa2fbb6485545a1e6b4b513517");
        assert_eq!(
            python_json(&serde_json::json!({"é": [true, null, "\n"]})),
            r#"{"\u00e9": [true, null, "\n"]}"#
        );
    }
}
