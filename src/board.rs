//! Board files: hardware as data (`boards/<name>/board.toml`). Core logic never reads them; the
//! binary turns them into typed settings. Unknown keys are errors so a typo fails loudly.

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// Where the room model comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneSource {
    /// The built-in demo office ([`crate::demo`]).
    DemoOffice,
    /// A scene directory (CAD input), relative paths resolved against the board file.
    Directory(PathBuf),
}

/// A validated board description.
#[derive(Debug, Clone)]
pub struct Board {
    /// Board name.
    pub name: String,
    /// One line on what the board is.
    pub description: String,
    /// The room model the node works on.
    pub scene: SceneSource,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoardToml {
    name: String,
    #[serde(default)]
    description: String,
    scene: SceneToml,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneToml {
    /// `"demo-office"` or a directory.
    source: String,
}

/// Why a board file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum BoardError {
    /// Unreadable.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not valid TOML or not the expected keys.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What the TOML reader said (with line and column).
        message: String,
    },
}

impl Board {
    /// Reads and validates a board file.
    pub fn load(path: &Path) -> Result<Board, BoardError> {
        let text = std::fs::read_to_string(path).map_err(|source| BoardError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses board TOML; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Board, BoardError> {
        let t: BoardToml = toml::from_str(text).map_err(|e| BoardError::Format {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let scene = match t.scene.source.as_str() {
            "demo-office" => SceneSource::DemoOffice,
            "" => {
                return Err(BoardError::Format {
                    path: path.to_path_buf(),
                    message: "scene.source is empty: use \"demo-office\" or a scene directory"
                        .into(),
                });
            }
            dir => SceneSource::Directory(path.parent().unwrap_or(Path::new(".")).join(dir)),
        };
        Ok(Board {
            name: t.name,
            description: t.description,
            scene,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim_board_file_parses() {
        let b = Board::load(Path::new("boards/sim/board.toml")).unwrap();
        assert_eq!(b.name, "sim");
        assert_eq!(b.scene, SceneSource::DemoOffice);
    }

    #[test]
    fn typos_are_errors() {
        let e = Board::parse(
            "name = \"x\"\n[scene]\nsourse = \"demo-office\"\n",
            Path::new("b.toml"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("sourse"), "{e}");
        let e = Board::parse(
            "name = \"x\"\n[scene]\nsource = \"\"\n",
            Path::new("b.toml"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let b = Board::parse(
            "name = \"x\"\n[scene]\nsource = \"../rooms/a\"\n",
            Path::new("/etc/luxnode/board.toml"),
        )
        .unwrap();
        assert_eq!(
            b.scene,
            SceneSource::Directory(PathBuf::from("/etc/luxnode/../rooms/a"))
        );
    }
}
