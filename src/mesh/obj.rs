//! Wavefront OBJ reading and writing with OpenSubdiv's tag syntax.

use super::ControlMesh;
use crate::error::{Error, ErrorKind, Result};
use std::path::Path;

/// Parses OBJ text. `file` names the source in error messages.
pub fn parse_obj(_text: &str, _file: Option<&str>) -> Result<ControlMesh> {
    Err(Error::new(ErrorKind::Usage, "OBJ parsing is not written yet"))
}

/// Reads and parses an OBJ file.
pub fn read_obj(path: &Path) -> Result<ControlMesh> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::new(ErrorKind::Io, e.to_string()).in_file(name.clone()))?;
    parse_obj(&text, Some(&name))
}
