//! The lab's error: which run, file or picture failed, and why.

use planner_core::PlannerError;
use std::path::PathBuf;

/// Why a lab run, report or picture failed. The message names the scene or the file; the
/// cause, where there is one, is the [`std::error::Error::source`].
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// The planner could not be set up: a parameter out of range, a bad scene, the start
    /// or the goal in collision.
    #[error(transparent)]
    Planner(#[from] PlannerError),
    /// A run names a scene that is not built in (runs replay the papers' scenes, whose
    /// operator paths are built in too).
    #[error("`{0}` is not a built-in scene")]
    UnknownScene(String),
    /// The memory bound leaves the trees no room.
    #[error(transparent)]
    Memory(#[from] planner_core::memory::BoundTooSmall),
    /// A directory could not be created.
    #[error("cannot create {}", path.display())]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A picture or a plot could not be drawn into its PNG file.
    #[error("{}: cannot draw", path.display())]
    Draw {
        /// The PNG file.
        path: PathBuf,
        /// What plotters (or the PNG encoder beneath it) said.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A live method name is none of [`crate::live::METHOD_NAMES`].
    #[error(
        "unknown live method `{0}`: expected one of {names}",
        names = crate::live::METHOD_NAMES.join(", ")
    )]
    UnknownMethod(String),
    /// A live method's `=α` is not a number in [0, 1].
    #[error("live method `{0}`: the α after `=` must be a number in [0, 1]")]
    MethodAlpha(String),
    /// A scene given by name or file could not be loaded.
    #[error("scene `{scene}`")]
    Scene {
        /// The name or file as given.
        scene: String,
        /// Why.
        source: scene::SceneError,
    },
    /// A live run's summary (the demo's `--summary-json`) could not be read.
    #[error("{origin}: not a haptic-loop summary: {reason}")]
    Summary {
        /// The file.
        origin: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A live sweep's runs.csv that cannot be read back.
    #[error("{origin}, line {line}: {reason}")]
    RunsCsv {
        /// The file.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// No TrueType font for the text of plots was found in the usual system places
    /// (see [`crate::register_font`]).
    #[error("no TrueType font found (DejaVuSans.ttf)")]
    NoFont,
}

impl LabError {
    /// [`LabError::Write`] for `path`.
    pub(crate) fn write(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> LabError {
        let path = path.into();
        move |source| LabError::Write { path, source }
    }

    /// [`LabError::CreateDir`] for `path`.
    pub(crate) fn create_dir(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> LabError {
        let path = path.into();
        move |source| LabError::CreateDir { path, source }
    }
}
