//! A streamed `.tg` block's CRC, read from the file's CRC table when the block arrives: the table
//! is checked whole when the stream opens (each of its blocks against the header's list) but not
//! kept, so a file's size costs a board nothing. A window of [`CRC_WINDOW`] CRCs is read at a time
//! (a pass reads its blocks in ascending order: one window serves many), and forgotten when a block
//! fails against it, in case it was the window that came back damaged.
#![deny(clippy::float_arithmetic)]

use super::ChunkSource;

/// CRCs read at a time (256 bytes: half an SD card's sector).
pub(crate) const CRC_WINDOW: usize = 64;

/// The CRCs of [`CRC_WINDOW`] consecutive blocks.
#[derive(Clone, Debug)]
pub(crate) struct CrcWindow {
    /// Where the CRC table starts in the file (bytes).
    table_at: u64,
    /// Blocks in the file (CRCs in the table).
    blocks: u32,
    /// First block of the window.
    first: u32,
    /// CRCs in the window (0: none read).
    len: u32,
    bytes: [u8; 4 * CRC_WINDOW],
    /// Reads issued and bytes read, for the stream's counters.
    pub reads: u32,
    pub bytes_read: u64,
}

impl CrcWindow {
    /// A window over the CRC table at `table_at` of a file of `blocks` blocks.
    pub(crate) const fn new(table_at: u64, blocks: u32) -> Self {
        Self {
            table_at,
            blocks,
            first: 0,
            len: 0,
            bytes: [0; 4 * CRC_WINDOW],
            reads: 0,
            bytes_read: 0,
        }
    }

    /// The CRC of block `b` (`None`: there is no such block), reading its window from `src` when it
    /// is not the one held.
    ///
    /// # Errors
    /// The medium's, when the window's read fails.
    pub(crate) fn crc<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        b: u32,
    ) -> Result<Option<u32>, C::Error> {
        if b >= self.blocks {
            return Ok(None);
        }
        if !(self.first..self.first + self.len).contains(&b) {
            let first = b - b % CRC_WINDOW as u32;
            let len = (self.blocks - first).min(CRC_WINDOW as u32);
            let buf = &mut self.bytes[..4 * len as usize];
            self.reads += 1;
            self.bytes_read += buf.len() as u64;
            self.len = 0;
            src.read_at(self.table_at + 4 * u64::from(first), buf)?;
            (self.first, self.len) = (first, len);
        }
        let i = 4 * (b - self.first) as usize;
        Ok(self
            .bytes
            .get(i..i + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])))
    }

    /// Forgets the window held (a block failed against it: read it again next time).
    pub(crate) fn forget(&mut self) {
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::MemSource;

    #[test]
    fn crcs_come_from_the_table_a_window_at_a_time() {
        // A "file" whose CRC table at byte 512 holds 100 CRCs: block b's is b * 3.
        let mut file = std::vec![0u8; 512 + 400];
        for b in 0..100u32 {
            file[512 + 4 * b as usize..][..4].copy_from_slice(&(b * 3).to_le_bytes());
        }
        let mut src = MemSource::new(&file);
        let mut w = CrcWindow::new(512, 100);
        assert_eq!(w.crc(&mut src, 5), Ok(Some(15)));
        assert_eq!(w.crc(&mut src, 63), Ok(Some(189)));
        assert_eq!((w.reads, w.bytes_read), (1, 256));
        // The last window is short: it ends with the table.
        assert_eq!(w.crc(&mut src, 99), Ok(Some(297)));
        assert_eq!((w.reads, w.bytes_read), (2, 256 + 144));
        assert_eq!(w.crc(&mut src, 100), Ok(None));
        w.forget();
        assert_eq!(w.crc(&mut src, 64), Ok(Some(192)));
        assert_eq!(w.reads, 3);
        // A read that fails gives the medium's error, and no window.
        let mut short = MemSource::new(&file[..600]);
        let mut w = CrcWindow::new(512, 100);
        assert!(w.crc(&mut short, 1).is_err());
        assert_eq!(w.len, 0);
    }
}
