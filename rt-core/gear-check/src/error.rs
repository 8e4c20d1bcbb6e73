//! A refusal of a measurement file: where (line and field) and what.

use std::fmt;

/// Why a measurement file is refused: the line (1-based; none for the file as a whole) and
/// the field (a header key or a column) it is about.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeasurementError {
    pub line: Option<usize>,
    pub field: String,
    pub problem: String,
}

impl MeasurementError {
    pub(crate) fn at(line: usize, field: &str, problem: impl Into<String>) -> Self {
        Self {
            line: Some(line),
            field: field.to_string(),
            problem: problem.into(),
        }
    }

    pub(crate) fn whole(field: &str, problem: impl Into<String>) -> Self {
        Self {
            line: None,
            field: field.to_string(),
            problem: problem.into(),
        }
    }
}

impl fmt::Display for MeasurementError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "line {line}, {}: {}", self.field, self.problem),
            None => write!(f, "{}: {}", self.field, self.problem),
        }
    }
}

impl std::error::Error for MeasurementError {}
