//! What is wrong with a scene, and where: the syntax error, or every
//! part's first invalid field with its line.

/// What is wrong with a scene, and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// The text is not a scene (syntax, unknown or missing fields, types,
    /// shapes with bad sizes).
    #[error("line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based.
        line: usize,
        /// 1-based.
        column: usize,
        /// What the parser says.
        message: String,
    },
    /// A field holds a value the scene cannot use: the first such field,
    /// and the first problem of each later part of the scene in `more`.
    #[error("{}{}", Problem::words(field, *line, message), more.iter().map(|p| format!("\n{p}")).collect::<String>())]
    Invalid {
        /// Path of the field, e.g. `species[1].count`.
        field: String,
        /// 1-based line of the field (or of the nearest enclosing one).
        line: Option<usize>,
        /// What is wrong.
        message: String,
        /// The problems of the later parts of the scene (box, species,
        /// start, stages, log, accuracy: the first of each part), in order.
        more: Vec<Problem>,
    },
}

/// One field that holds a value the scene cannot use.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Path of the field, e.g. `log.path`.
    pub field: String,
    /// 1-based line of the field (or of the nearest enclosing one).
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl Problem {
    fn words(field: &str, line: Option<usize>, message: &str) -> String {
        let at = line.map(|l| format!("line {l}: ")).unwrap_or_default();
        format!("{at}{field}: {message}")
    }
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&Problem::words(&self.field, self.line, &self.message))
    }
}

impl SceneError {
    /// The error of `problems` (at least one), each placed by `line_of`.
    pub(super) fn invalid(
        problems: Vec<(String, String)>,
        line_of: impl Fn(&str) -> Option<usize>,
    ) -> Self {
        let mut problems = problems.into_iter().map(|(field, message)| Problem {
            line: line_of(&field),
            field,
            message,
        });
        let first = problems.next().expect("an invalid scene has a problem");
        SceneError::Invalid {
            field: first.field,
            line: first.line,
            message: first.message,
            more: problems.collect(),
        }
    }
}
