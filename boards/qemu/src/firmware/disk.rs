//! The disk image the streaming build reads its model from, on the semihosting host: semihosting
//! file reads (SYS_OPEN, SYS_FLEN, SYS_SEEK, SYS_READ) behind an embedded-sdmmc
//! [`BlockDevice`](embedded_sdmmc::BlockDevice) ([`HostDisk`]), so that the volume, directory and
//! file are found and read by the code that reads an SD card on SPI.

use core::cell::Cell;

use cortex_m_semihosting::{nr, syscall};
use embedded_sdmmc::{Block, BlockCount, BlockDevice, BlockIdx};

/// The image's absolute path, NUL-terminated for SYS_OPEN (build.rs).
pub const IMAGE: &str = concat!(env!("POCKETSPLAT_PDA_IMAGE_FILE"), "\0");

/// Why a semihosting file operation failed (the host returned -1, or read short).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostIoError {
    /// SYS_OPEN or SYS_FLEN of the image failed.
    Open,
    /// SYS_SEEK or SYS_READ of this 512-byte block failed or came short.
    Read(u32),
    /// The image is opened read-only.
    Write(u32),
}

impl core::fmt::Display for HostIoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            HostIoError::Open => write!(f, "cannot open {}", &IMAGE[..IMAGE.len() - 1]),
            HostIoError::Read(b) => write!(f, "reading block {b} failed"),
            HostIoError::Write(b) => write!(f, "block {b}: the image is read-only"),
        }
    }
}

impl core::error::Error for HostIoError {}

/// A disk image on the semihosting host, 512-byte blocks, read-only.
pub struct HostDisk {
    handle: usize,
    /// 512-byte blocks in the image.
    pub blocks: u32,
    /// 512-byte blocks read so far.
    pub reads: Cell<u32>,
}

impl HostDisk {
    /// Opens the image at the NUL-terminated `path` (binary, read-only).
    pub fn open(path: &str) -> Result<Self, HostIoError> {
        let len = path.len() - 1;
        // SAFETY: SYS_OPEN reads `len` bytes of the NUL-terminated string at the pointer,
        // which lives for the call; nothing else is touched.
        let handle = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, len) };
        if handle as isize == -1 {
            return Err(HostIoError::Open);
        }
        // SAFETY: SYS_FLEN takes a handle returned by SYS_OPEN.
        let bytes = unsafe { syscall!(FLEN, handle) } as isize;
        if bytes < 0 {
            return Err(HostIoError::Open);
        }
        Ok(Self {
            handle,
            blocks: (bytes as usize / Block::LEN) as u32,
            reads: Cell::new(0),
        })
    }
}

impl BlockDevice for HostDisk {
    type Error = HostIoError;

    fn read(&self, blocks: &mut [Block], start: BlockIdx) -> Result<(), HostIoError> {
        for (i, b) in blocks.iter_mut().enumerate() {
            let idx = start.0.saturating_add(i as u32);
            let at = (idx as usize)
                .checked_mul(Block::LEN)
                .filter(|_| idx < self.blocks)
                .ok_or(HostIoError::Read(idx))?;
            // SAFETY: SYS_SEEK takes an open handle and an absolute offset.
            if unsafe { syscall!(SEEK, self.handle, at) } != 0 {
                return Err(HostIoError::Read(idx));
            }
            // SAFETY: SYS_READ writes at most `Block::LEN` bytes into `b.contents`, which
            // is that long and borrowed mutably for the call.
            let left = unsafe { syscall!(READ, self.handle, b.contents.as_mut_ptr(), Block::LEN) };
            if left != 0 {
                return Err(HostIoError::Read(idx));
            }
            self.reads.set(self.reads.get().wrapping_add(1));
        }
        Ok(())
    }

    fn write(&self, _: &[Block], start: BlockIdx) -> Result<(), HostIoError> {
        Err(HostIoError::Write(start.0))
    }

    fn num_blocks(&self) -> Result<BlockCount, HostIoError> {
        Ok(BlockCount(self.blocks))
    }
}
