//! Where in a scene file something is: line numbers and dotted key paths from byte offsets.

use crate::error::{Error, ErrorKind};
use glam::Vec3;
use std::collections::BTreeMap;
use std::ops::Range;

/// Source text with its name, for located errors.
pub(super) struct Src<'a> {
    pub(super) name: String,
    pub(super) text: &'a str,
}

impl Src<'_> {
    pub(super) fn line_of(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    /// The dotted key path at `offset` (`camera.fov`, `mesh[2].file`), from the table headers
    /// above it and the key on its line.
    pub(super) fn key_at(&self, offset: usize) -> String {
        let line_no = self.line_of(offset);
        let mut header = String::new();
        let mut arrays: BTreeMap<String, usize> = BTreeMap::new();
        let mut key = String::new();
        for (i, raw) in self.text.lines().enumerate() {
            let line = strip_comment(raw).trim();
            if i + 1 > line_no {
                break;
            }
            if let Some(name) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
                let name = name.trim().to_string();
                let n = arrays.entry(name.clone()).or_insert(0);
                header = format!("{name}[{n}]");
                *n += 1;
                key.clear();
            } else if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                header = name.trim().to_string();
                key.clear();
            } else if i + 1 == line_no {
                if let Some((k, _)) = line.split_once('=') {
                    key = k.trim().trim_matches('"').to_string();
                }
            }
        }
        match (header.is_empty(), key.is_empty()) {
            (true, _) => key,
            (false, true) => header,
            (false, false) => format!("{header}.{key}"),
        }
    }

    pub(super) fn err(&self, span: Range<usize>, message: impl Into<String>) -> Error {
        let key = self.key_at(span.start);
        let mut e = Error::new(ErrorKind::Parse, message)
            .in_file(self.name.clone())
            .at_line(self.line_of(span.start));
        if !key.is_empty() {
            e = e.element(format!("key '{key}'"));
        }
        e
    }
}

fn strip_comment(line: &str) -> &str {
    // Good enough for key lookup: '#' inside strings is rare in scene files.
    match line.find('#') {
        Some(i) => &line[..i],
        None => line,
    }
}

pub(super) fn finite3(v: Vec3) -> bool {
    v.is_finite()
}
