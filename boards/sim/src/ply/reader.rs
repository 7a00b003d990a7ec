//! The bytes under the parser: a read-ahead thread (so that inflating a `.ply.gz` runs beside the
//! parse), a cap on the bytes read (the `ply` limit) and the magic prefix.

use std::io::{self, Read};

use super::error::PlyError;
use crate::limits::Exceeded;

/// Bytes a [`read_ahead`] thread reads at a time, and chunks it may hold unread.
const AHEAD_CHUNK: usize = 1 << 18;
const AHEAD_CHUNKS: usize = 4;

/// Runs `body` on a reader of `inner` that a second thread reads ahead of it, at most
/// `AHEAD_CHUNKS × AHEAD_CHUNK` bytes ahead: inflating a `.ply.gz` is about a third of reading it,
/// and the parsing need not wait for it. Errors arrive in order, as `inner` raised them.
pub(super) fn read_ahead<T>(mut inner: impl Read + Send, body: impl FnOnce(Ahead) -> T) -> T {
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel(AHEAD_CHUNKS);
        scope.spawn(move || loop {
            let mut chunk = std::vec![0u8; AHEAD_CHUNK];
            let mut n = 0;
            let end = loop {
                match inner.read(&mut chunk[n..]) {
                    Ok(0) => break None,
                    Ok(k) => {
                        n += k;
                        if n == chunk.len() {
                            break Some(Ok(()));
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => break Some(Err(e)),
                }
            };
            chunk.truncate(n);
            // A send fails once `body` has returned and dropped the reader: then stop.
            if n > 0 && tx.send(Ok(chunk)).is_err() {
                return;
            }
            match end {
                Some(Ok(())) => {}
                Some(Err(e)) => {
                    let _ = tx.send(Err(e));
                    return;
                }
                None => return,
            }
        });
        // `body` owns the receiving end, so it is dropped (and the thread released) before the
        // scope waits for the thread, however `body` returns.
        body(Ahead {
            rx,
            chunk: Vec::new(),
            at: 0,
        })
    })
}

/// The reading end of [`read_ahead`].
pub(super) struct Ahead {
    rx: std::sync::mpsc::Receiver<io::Result<Vec<u8>>>,
    chunk: Vec<u8>,
    at: usize,
}

impl Read for Ahead {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.at == self.chunk.len() {
            match self.rx.recv() {
                Ok(Ok(chunk)) => {
                    self.chunk = chunk;
                    self.at = 0;
                }
                Ok(Err(e)) => return Err(e),
                // The thread has finished: the end of `inner`.
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.chunk.len() - self.at);
        buf[..n].copy_from_slice(&self.chunk[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A reader that fails once more than `max` bytes come through it (the `ply` limit on the
/// decompressed stream).
pub(super) struct Capped<R> {
    inner: R,
    left: u64,
    max: u64,
}

impl<R> Capped<R> {
    pub(super) fn new(inner: R, max: u64) -> Self {
        Self {
            inner,
            left: max,
            max,
        }
    }
}

/// The error a [`Capped`] reader fails with.
#[derive(Debug)]
struct CapReached(u64);

impl std::fmt::Display for CapReached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "more than {} bytes", self.0)
    }
}

impl std::error::Error for CapReached {}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.left == 0 {
            let mut probe = [0u8; 1];
            return match self.inner.read(&mut probe)? {
                0 => Ok(0),
                _ => Err(io::Error::other(CapReached(self.max))),
            };
        }
        let n = buf
            .len()
            .min(usize::try_from(self.left).unwrap_or(usize::MAX));
        let k = self.inner.read(buf.get_mut(..n).unwrap_or_default())?;
        self.left = self.left.saturating_sub(k as u64);
        Ok(k)
    }
}

/// The [`PlyError::Limit`] for an I/O error a [`Capped`] reader raised.
pub(super) fn capped(file: &str, e: &io::Error) -> Option<PlyError> {
    let cap = e.get_ref()?.downcast_ref::<CapReached>()?;
    Some(PlyError::Limit {
        file: file.to_owned(),
        error: Exceeded {
            name: "ply",
            what: "decompressed size in bytes".into(),
            value: cap.0.saturating_add(1),
            max: cap.0,
        },
    })
}

/// Fills `buf` as far as the reader allows; returns how many bytes were read.
pub(super) fn read_prefix(reader: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while let Some(rest) = buf.get_mut(n..).filter(|rest| !rest.is_empty()) {
        match reader.read(rest) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}
