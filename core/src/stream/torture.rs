//! Sources that mistreat another source, for torture tests (docs/ARCHITECTURE.md, Conventions 6; embedded-sdmmc's
//! `tests/read_file.rs`): reads split into odd chunks and issued backwards, and reads that fail or
//! arrive damaged at random, from a seed.

use super::ChunkSource;

/// Splits every read into pieces that end at multiples of `chunk` bytes (a 512-byte sector, a prime),
/// and issues them last piece first when `reversed`.
#[derive(Clone, Copy, Debug)]
pub struct Chunked<S> {
    inner: S,
    chunk: u64,
    reversed: bool,
    /// Pieces read so far.
    pub pieces: u64,
}

impl<S> Chunked<S> {
    /// `inner` read `chunk` bytes at a time (at least 1).
    pub fn new(inner: S, chunk: usize, reversed: bool) -> Self {
        Self {
            inner,
            chunk: chunk.max(1) as u64,
            reversed,
            pieces: 0,
        }
    }
}

impl<S: ChunkSource> ChunkSource for Chunked<S> {
    type Error = S::Error;
    fn byte_len(&self) -> Option<u64> {
        self.inner.byte_len()
    }
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), S::Error> {
        let end = offset + buf.len() as u64;
        let mut cuts = offset;
        // Piece k covers [cut_k, cut_{k+1}); walk them forwards or backwards.
        let mut pieces: u64 = 0;
        while cuts < end {
            cuts = ((cuts / self.chunk) + 1) * self.chunk;
            pieces += 1;
        }
        for k in 0..pieces {
            let k = if self.reversed { pieces - 1 - k } else { k };
            let lo = if k == 0 {
                offset
            } else {
                (offset / self.chunk + k) * self.chunk
            };
            let hi = ((offset / self.chunk + k + 1) * self.chunk).min(end);
            let piece = &mut buf[(lo - offset) as usize..(hi - offset) as usize];
            self.inner.read_at(lo, piece)?;
            self.pieces += 1;
        }
        Ok(())
    }
}

/// A read [`Flaky`] made fail, or the inner source's own error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlakyError<E> {
    /// A failure injected at random.
    Injected,
    /// The inner source failed.
    Inner(E),
}

/// Fails `fail_pct` % of reads and flips one bit in `corrupt_pct` % of the others, at random from a
/// seed (xorshift64*), so a run is repeatable.
#[derive(Clone, Copy, Debug)]
pub struct Flaky<S> {
    inner: S,
    state: u64,
    fail_pct: u32,
    corrupt_pct: u32,
    /// Reads failed so far.
    pub failed: u32,
    /// Reads damaged so far.
    pub corrupted: u32,
    /// Reads so far.
    pub reads: u32,
}

impl<S> Flaky<S> {
    /// `inner` with `fail_pct` % failed and `corrupt_pct` % damaged reads, from `seed`.
    pub fn new(inner: S, seed: u64, fail_pct: u32, corrupt_pct: u32) -> Self {
        Self {
            inner,
            state: seed | 1,
            fail_pct,
            corrupt_pct,
            failed: 0,
            corrupted: 0,
            reads: 0,
        }
    }

    fn next(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

impl<S: ChunkSource> ChunkSource for Flaky<S> {
    type Error = FlakyError<S::Error>;
    fn byte_len(&self) -> Option<u64> {
        self.inner.byte_len()
    }
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.reads += 1;
        let roll = (self.next() % 100) as u32;
        if roll < self.fail_pct {
            self.failed += 1;
            return Err(FlakyError::Injected);
        }
        self.inner.read_at(offset, buf).map_err(FlakyError::Inner)?;
        if roll < self.fail_pct + self.corrupt_pct && !buf.is_empty() {
            let r = self.next();
            let at = (r % buf.len() as u64) as usize;
            buf[at] ^= 1 << ((r >> 32) % 8);
            self.corrupted += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::MemSource;
    use super::*;

    #[test]
    fn chunked_reads_give_the_same_bytes_in_any_order() {
        let file: [u8; 3000] = core::array::from_fn(|i| (i * 7 + i / 256) as u8);
        for chunk in [1, 7, 509, 512, 4096] {
            for reversed in [false, true] {
                let mut src = Chunked::new(MemSource::new(&file), chunk, reversed);
                let mut buf = [0u8; 1100];
                src.read_at(1234, &mut buf).unwrap();
                assert_eq!(
                    &buf[..],
                    &file[1234..2334],
                    "chunk {chunk} reversed {reversed}"
                );
                assert_eq!(
                    src.pieces as usize,
                    (2334usize).div_ceil(chunk) - 1234 / chunk
                );
                assert!(src.read_at(2999, &mut [0u8; 2]).is_err());
            }
        }
    }

    #[test]
    fn flaky_fails_and_damages_about_as_asked() {
        let file = [0u8; 64];
        let mut src = Flaky::new(MemSource::new(&file), 42, 10, 10);
        let mut damaged = 0;
        for _ in 0..10_000 {
            let mut buf = [0u8; 64];
            if src.read_at(0, &mut buf).is_ok() && buf != file {
                damaged += 1;
            }
        }
        assert_eq!(damaged, src.corrupted);
        assert!((800..1200).contains(&src.failed), "{} failed", src.failed);
        assert!(
            (800..1200).contains(&src.corrupted),
            "{} damaged",
            src.corrupted
        );
    }
}
