//! Where each field of a RON text is: a light scan (comments, strings,
//! brackets, `key:` pairs) that maps field paths such as
//! `species[1].shape.a` to line numbers, so that a validation error found
//! after deserialisation can still name the line.

/// Field paths and the line (1-based) where each starts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outline {
    entries: Vec<(String, usize)>,
}

#[derive(Debug)]
struct Frame {
    /// Path of the container.
    path: String,
    /// List (`[...]`) or struct/tuple (`(...)`, `{...}`).
    list: bool,
    /// Element index (lists) or tuple position (parentheses without keys).
    index: usize,
    /// The key whose value is being read (structs).
    key: Option<String>,
    /// Whether the current list element has been recorded.
    element_seen: bool,
}

impl Frame {
    /// The path of the value now being read in this container.
    fn value_path(&self) -> String {
        match (&self.key, self.list) {
            (Some(k), _) => join(&self.path, k),
            (None, true) => format!("{}[{}]", self.path, self.index),
            (None, false) => self.path.clone(),
        }
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

impl Outline {
    /// Scans `text`; never fails (whatever it cannot read it skips).
    pub fn of(text: &str) -> Self {
        let bytes = text.as_bytes();
        let mut out = Outline::default();
        let mut stack: Vec<Frame> = Vec::new();
        let mut line = 1;
        let mut i = 0;
        // The identifier just read, with its line, not yet known to be a key.
        let mut ident: Option<(String, usize)> = None;
        while i < bytes.len() {
            let c = bytes[i];
            match c {
                b'\n' => {
                    line += 1;
                    i += 1;
                }
                b' ' | b'\t' | b'\r' => i += 1,
                b'/' if bytes.get(i + 1) == Some(&b'/') => {
                    while i < bytes.len() && bytes[i] != b'\n' {
                        i += 1;
                    }
                }
                b'/' if bytes.get(i + 1) == Some(&b'*') => {
                    let mut depth = 0;
                    while i < bytes.len() {
                        if bytes[i] == b'/' && bytes.get(i + 1) == Some(&b'*') {
                            depth += 1;
                            i += 2;
                        } else if bytes[i] == b'*' && bytes.get(i + 1) == Some(&b'/') {
                            depth -= 1;
                            i += 2;
                            if depth == 0 {
                                break;
                            }
                        } else {
                            if bytes[i] == b'\n' {
                                line += 1;
                            }
                            i += 1;
                        }
                    }
                }
                b'"' => {
                    out.element_start(&mut stack, line);
                    i += 1;
                    while i < bytes.len() && bytes[i] != b'"' {
                        if bytes[i] == b'\\' {
                            i += 1;
                        }
                        if i < bytes.len() && bytes[i] == b'\n' {
                            line += 1;
                        }
                        i += 1;
                    }
                    i += 1;
                    ident = None;
                }
                b'(' | b'[' | b'{' => {
                    out.element_start(&mut stack, line);
                    let path = stack.last().map(Frame::value_path).unwrap_or_default();
                    stack.push(Frame {
                        path,
                        list: c == b'[',
                        index: 0,
                        key: None,
                        element_seen: false,
                    });
                    ident = None;
                    i += 1;
                }
                b')' | b']' | b'}' => {
                    stack.pop();
                    ident = None;
                    i += 1;
                }
                b',' => {
                    if let Some(f) = stack.last_mut() {
                        f.key = None;
                        f.index += 1;
                        f.element_seen = false;
                    }
                    ident = None;
                    i += 1;
                }
                b':' => {
                    if let (Some((name, l)), Some(f)) = (ident.take(), stack.last_mut())
                        && !f.list
                    {
                        let path = join(&f.path, &name);
                        out.entries.push((path, l));
                        f.key = Some(name);
                        f.element_seen = true;
                    }
                    i += 1;
                }
                c if c.is_ascii_alphabetic() || c == b'_' => {
                    let start = i;
                    while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_')
                    {
                        i += 1;
                    }
                    out.element_start(&mut stack, line);
                    ident = Some((text[start..i].to_string(), line));
                }
                _ => {
                    out.element_start(&mut stack, line);
                    ident = None;
                    i += 1;
                }
            }
        }
        out
    }

    /// Records the start of a list element the first time anything of it
    /// is read.
    fn element_start(&mut self, stack: &mut [Frame], line: usize) {
        if let Some(f) = stack.last_mut()
            && f.list
            && !f.element_seen
        {
            f.element_seen = true;
            self.entries
                .push((format!("{}[{}]", f.path, f.index), line));
        }
    }

    /// The line of `path`, or of its nearest enclosing field that is in
    /// the text (a defaulted field has no line of its own).
    pub fn line_of(&self, path: &str) -> Option<usize> {
        let mut p = path;
        loop {
            if let Some((_, l)) = self.entries.iter().find(|(q, _)| q == p) {
                return Some(*l);
            }
            let cut = p.rfind(['.', '['])?;
            p = &p[..cut];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"// a scene
Scene(
    seed: 7,
    box: (12.0, 12.0, 12.0),
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 1.0, b: 0.5, c: 0.5), count: 256),
        /* a comment ( with [ brackets */
        Species(
            name: "ball, (round)",
            shape: Sphere(radius: 0.5),
            count: 0,
        ),
    ],
    stages: [
        Compress(packing_fraction: 0.50),
        MonteCarlo(ensemble: Npt(pressure: 3.0), sweeps: 20000),
    ],
)
"#;

    #[test]
    fn fields_are_found_on_their_lines() {
        let o = Outline::of(TEXT);
        assert_eq!(o.line_of("seed"), Some(3));
        assert_eq!(o.line_of("box"), Some(4));
        assert_eq!(o.line_of("species[0].shape.b"), Some(6));
        assert_eq!(o.line_of("species[1]"), Some(8));
        assert_eq!(o.line_of("species[1].count"), Some(11));
        assert_eq!(o.line_of("species[1].shape.radius"), Some(10));
        assert_eq!(o.line_of("stages[1].ensemble.pressure"), Some(16));
        assert_eq!(o.line_of("stages[0].packing_fraction"), Some(15));
    }

    #[test]
    fn missing_fields_fall_back_to_the_enclosing_one() {
        let o = Outline::of(TEXT);
        assert_eq!(o.line_of("species[1].mass"), Some(8));
        assert_eq!(o.line_of("stages[1].tune_sweeps"), Some(16));
        assert_eq!(o.line_of("log"), None);
    }
}
