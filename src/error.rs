//! Errors that name where bad input came from: file, line and element.

use std::fmt;

/// What went wrong, broadly; the command-line tool maps every kind of bad input to exit code 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The input could not be read (missing file, permission).
    Io,
    /// Text that is not valid input (syntax, numbers, unknown forms).
    Parse,
    /// Well-formed text describing an invalid mesh (indices out of range, degenerate or
    /// non-manifold faces the library does not accept, invalid sharpness).
    Topology,
    /// A caller asked for something the library does not offer (options, levels).
    Usage,
    /// The GPU backend failed: no Vulkan adapter, a device or kernel error, a traversal bound
    /// exceeded.
    Gpu,
}

/// An error with the location of the offending element, printed as
/// `file:line: element: message` (parts that are unknown are left out).
#[derive(Clone, Debug, PartialEq)]
pub struct Error {
    /// Broad category.
    pub kind: ErrorKind,
    /// Source file, when the input came from one.
    pub file: Option<String>,
    /// 1-based line number in `file`, when known.
    pub line: Option<usize>,
    /// The element at fault, e.g. `face 12`, `vertex 7`, `tag crease`.
    pub element: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl Error {
    /// A new error of `kind` with a message and no location yet.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error {
            kind,
            file: None,
            line: None,
            element: None,
            message: message.into(),
        }
    }

    /// Sets the file name unless one is set already.
    pub fn in_file(mut self, file: impl Into<String>) -> Self {
        if self.file.is_none() {
            self.file = Some(file.into());
        }
        self
    }

    /// Sets the 1-based line number unless one is set already.
    pub fn at_line(mut self, line: usize) -> Self {
        if self.line.is_none() {
            self.line = Some(line);
        }
        self
    }

    /// Sets the element description unless one is set already.
    pub fn element(mut self, element: impl Into<String>) -> Self {
        if self.element.is_none() {
            self.element = Some(element.into());
        }
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut prefix = String::new();
        if let Some(file) = &self.file {
            prefix.push_str(file);
            if let Some(line) = self.line {
                prefix.push_str(&format!(":{line}"));
            }
            prefix.push_str(": ");
        } else if let Some(line) = self.line {
            prefix.push_str(&format!("line {line}: "));
        }
        if let Some(el) = &self.element {
            prefix.push_str(el);
            prefix.push_str(": ");
        }
        write!(f, "{prefix}{}", self.message)
    }
}

impl std::error::Error for Error {}

/// Result alias used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;
