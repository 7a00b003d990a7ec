//! Streaming on the desktop: the sources a simulator reads a model from (a host file, HTTP/1.1 byte
//! ranges from any web server, a FAT disk image through embedded-sdmmc) and the frame loop that
//! streams a `.tg`, a `.qs` or a scene pack until it converges (`pocketsplat render --stream`).

pub mod cmd;
pub mod file;
pub mod http;
pub mod pack;
pub mod run;
pub mod sd;

pub use file::FileSource;
pub use http::{HttpError, HttpSource};
pub use run::{stream_render, OwnedStream, StreamOptions, StreamOutcome};
pub use sd::FileBlockDevice;
