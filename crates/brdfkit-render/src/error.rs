//! Typed errors: reading a scene ([`SceneError`]), rendering ([`RenderError`]) and
//! writing images ([`OutputError`]). Every message starts with the file it is about.

use brdfkit_core::ModelError;
use brdfkit_merl::MerlError;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A scene file that cannot be read, parsed, or that asks for something impossible.
///
/// The CLI treats every variant as bad input (exit code 2).
#[derive(Debug, Error)]
pub enum SceneError {
    /// The scene file itself cannot be read, or is not UTF-8 text.
    #[error(transparent)]
    Read(#[from] brdfkit_core::text::TextFileError),

    /// Not valid TOML, an unknown key, a value of the wrong type or a missing field.
    /// The message of the TOML parser names the key and the line.
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },

    /// A value outside its domain, or keys that contradict each other.
    #[error("{}: `{key}`: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        /// What is wrong.
        message: String,
    },

    /// A file the scene refers to (model JSON, MERL table, environment image) cannot be
    /// read.
    #[error("{}: `{key}`: cannot read {}: {source}", scene.display(), file.display())]
    File {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        /// The referenced file.
        file: PathBuf,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },

    /// A model JSON file that is not valid JSON.
    #[error("{}: `{key}`: {} is not valid JSON: {source}", scene.display(), file.display())]
    ModelJson {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        /// The referenced file.
        file: PathBuf,
        #[source]
        /// The underlying error.
        source: serde_json::Error,
    },

    /// A model description that `brdfkit_models::from_json` rejects (unknown model,
    /// unknown parameter, parameter out of its domain). `file` is the JSON file when the
    /// model was given by path.
    #[error("{}: `{key}`{}: {source}", scene.display(), file.as_ref().map(|f| format!(" ({})", f.display())).unwrap_or_default())]
    Model {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        /// The model JSON file, when the model was given by path.
        file: Option<PathBuf>,
        #[source]
        /// The underlying error.
        source: Box<ModelError>,
    },

    /// An RGL-EPFL `.bsdf` that cannot be read (its message names the file and field).
    #[error("{}: `{key}`: {source}", scene.display())]
    Measured {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        #[source]
        /// The underlying error.
        source: Box<brdfkit_rgl::RglError>,
    },
    /// A MERL table that cannot be read (its message names the table file).
    #[error("{}: `{key}`: {source}", scene.display())]
    Table {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        #[source]
        /// The underlying error.
        source: Box<MerlError>,
    },

    /// An environment image that cannot be decoded or holds unusable values.
    #[error("{}: `{key}`: {}: {message}", scene.display(), file.display())]
    Image {
        /// The scene file.
        scene: PathBuf,
        /// The dotted key of the scene it concerns.
        key: String,
        /// The referenced file.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl SceneError {
    /// The scene file the error is about.
    pub fn scene_path(&self) -> &Path {
        match self {
            SceneError::Read(e) => e.path(),
            SceneError::Syntax { path, .. } | SceneError::Invalid { path, .. } => path,
            SceneError::File { scene, .. }
            | SceneError::ModelJson { scene, .. }
            | SceneError::Model { scene, .. }
            | SceneError::Table { scene, .. }
            | SceneError::Measured { scene, .. }
            | SceneError::Image { scene, .. } => scene,
        }
    }

    /// The dotted key the error is about (`camera.fov`, `light[1].intensity`), when one
    /// applies.
    pub fn key(&self) -> Option<&str> {
        match self {
            SceneError::Read(_) | SceneError::Syntax { .. } => None,
            SceneError::Invalid { key, .. }
            | SceneError::File { key, .. }
            | SceneError::ModelJson { key, .. }
            | SceneError::Model { key, .. }
            | SceneError::Table { key, .. }
            | SceneError::Measured { key, .. }
            | SceneError::Image { key, .. } => Some(key),
        }
    }
}

/// A render that cannot run or produced something unusable.
#[derive(Debug, Error)]
pub enum RenderError {
    /// A scene changed after reading into something unusable (the fields of
    /// [`crate::Scene`] are public; [`crate::Scene::read`] never produces these).
    #[error("{}: `{key}`: {message}", scene.display())]
    Invalid {
        /// The scene file.
        scene: PathBuf,
        /// The field of the scene.
        key: &'static str,
        /// What is wrong.
        message: String,
    },

    /// A pixel came out NaN or infinite: a material returned a non-finite value.
    #[error(
        "{}: pixel ({x}, {y}) is not finite ({value:?}): the material returned a non-finite value",
        scene.display()
    )]
    NonFinite {
        /// The scene file.
        scene: PathBuf,
        /// Pixel column.
        x: usize,
        /// Pixel row.
        y: usize,
        /// The pixel value.
        value: [f64; 3],
    },
}

/// An image that cannot be written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// Creating, writing or renaming the file failed (the one writer's error: the
    /// destination and the step).
    #[error(transparent)]
    Io(#[from] brdfkit_core::atomic::WriteError),
    /// The image encoder failed.
    #[error("{}: encoding failed: {source}", path.display())]
    Encode {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: image::ImageError,
    },
}
