//! Errors of the command-line tool and their exit codes.

use crate::span::{line_col, line_text};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// One problem found in a scene file: the key it concerns (a dotted path such as
/// `materials[1].E`), where it sits in the file, and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// The key path, when the problem concerns one key or table.
    pub key: Option<String>,
    /// Byte span in the scene text (the key, or its enclosing table if the key is absent).
    pub span: Option<Range<usize>>,
    /// What is wrong.
    pub message: String,
}

/// Problems found in a scene file, rendered with file, line and column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    /// The scene file.
    pub file: PathBuf,
    /// The scene text (to turn spans into lines and columns).
    pub text: String,
    /// The problems, in file order where known.
    pub items: Vec<Diagnostic>,
}

impl SceneError {
    /// A scene error with the given problems.
    pub fn new(file: &Path, text: &str, items: Vec<Diagnostic>) -> Self {
        Self {
            file: file.to_path_buf(),
            text: text.to_string(),
            items,
        }
    }

    /// `(line, column)` of problem `i`, if it has a location.
    pub fn location(&self, i: usize) -> Option<(usize, usize)> {
        let d = self.items.get(i)?;
        d.span.as_ref().map(|s| line_col(&self.text, s.start))
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = self.file.display();
        for (i, d) in self.items.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            match self.location(i) {
                Some((line, col)) => write!(f, "error: {file}:{line}:{col}: ")?,
                None => write!(f, "error: {file}: ")?,
            }
            if let Some(key) = &d.key {
                write!(f, "`{key}`: ")?;
            }
            write!(f, "{}", d.message)?;
            if let Some((line, col)) = self.location(i) {
                let src = line_text(&self.text, line);
                let width = d
                    .span
                    .as_ref()
                    .map_or(1, |s| {
                        let end = s.end.min(self.text.len());
                        let start = s.start.min(end);
                        self.text
                            .get(start..end)
                            .map_or(1, |t| t.lines().next().unwrap_or("").chars().count())
                    })
                    .max(1);
                let pad = " ".repeat(col.saturating_sub(1));
                write!(
                    f,
                    "\n  {line:>4} | {src}\n       | {pad}{}",
                    "^".repeat(width)
                )?;
            }
        }
        Ok(())
    }
}

impl std::error::Error for SceneError {}

/// An error of the command-line tool; each kind has its exit code.
#[derive(Debug)]
pub enum CliError {
    /// Bad input: a scene error, a missing or unreadable input file, an unusable output
    /// directory (exit code 2).
    BadInput(String),
    /// The run became numerically unstable (exit code 3).
    Instability(String),
    /// Anything else (exit code 1).
    Other(String),
    /// The run was stopped by a termination signal after writing a checkpoint
    /// (exit code 128 + the signal number: 130 for SIGINT, 143 for SIGTERM).
    Interrupted {
        /// The signal number (2 for SIGINT, 15 for SIGTERM).
        signal: i32,
        /// What happened and how to resume.
        message: String,
    },
}

impl CliError {
    /// The process exit code: 2 bad input, 3 numerical instability, 128 + signal number when
    /// interrupted (130 SIGINT, 143 SIGTERM), 1 anything else.
    pub fn exit_code(&self) -> i32 {
        match self {
            CliError::BadInput(_) => 2,
            CliError::Instability(_) => 3,
            CliError::Other(_) => 1,
            CliError::Interrupted { signal, .. } => 128 + signal,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::BadInput(m)
            | CliError::Instability(m)
            | CliError::Other(m)
            | CliError::Interrupted { message: m, .. } => f.write_str(m),
        }
    }
}

impl std::error::Error for CliError {}

impl From<SceneError> for CliError {
    fn from(e: SceneError) -> Self {
        CliError::BadInput(e.to_string())
    }
}

impl From<mpm_io::IoError> for CliError {
    fn from(e: mpm_io::IoError) -> Self {
        CliError::Other(format!("error: {e}"))
    }
}
