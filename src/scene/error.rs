//! Errors from loading a scene. Every message names the file and, where there is one, the
//! glTF element at fault (`mesh 3 primitive 0`, `image 2`, `node 7`, ...).

/// A scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read. The OS error is the [`source`](std::error::Error::source),
    /// not part of this message: printers of the whole chain (`rqr: error:`,
    /// [`crate::error_chain`]) add it once.
    #[error("{file}: cannot read")]
    Io {
        /// The file (or `built-in`).
        file: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The container is broken: truncated or malformed GLB, invalid JSON, wrong glTF version.
    #[error("{file}: {message}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// One element of the file is invalid or cannot be loaded.
    #[error("{file}: {element}: {message}")]
    Element {
        /// The file.
        file: String,
        /// The element, e.g. `mesh 3 primitive 0` or `image 2`.
        element: String,
        /// What is wrong.
        message: String,
    },
    /// `extensionsRequired` lists extensions rqr does not implement.
    #[error("{file}: requires glTF extension(s) rqr does not support: {}", extensions.join(", "))]
    UnsupportedExtensions {
        /// The file.
        file: String,
        /// The unsupported required extensions.
        extensions: Vec<String>,
        /// Every extension the file names, with how rqr treats it (for `rqr info`).
        all: Vec<super::extensions::ExtensionStatus>,
    },
}

impl SceneError {
    /// Builds an [`SceneError::Element`].
    pub fn element(
        file: impl Into<String>,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self::Element {
            file: file.into(),
            element: element.into(),
            message: message.into(),
        }
    }
}
