//! A disk image on the host as an embedded-sdmmc [`BlockDevice`], so that the simulator reads a
//! model from a FAT image through exactly the code that reads it from an SD card.

use std::cell::{Cell, RefCell};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

use embedded_sdmmc::{Block, BlockCount, BlockDevice, BlockIdx};

/// A disk image (MBR, then a FAT volume) in a host file, 512-byte blocks.
#[derive(Debug)]
pub struct FileBlockDevice {
    file: RefCell<File>,
    blocks: u32,
    /// 512-byte blocks read so far.
    pub reads: Cell<u64>,
}

impl FileBlockDevice {
    /// Opens the image at `path` read-only.
    ///
    /// # Errors
    /// When it cannot be opened.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        let blocks = u32::try_from(len / Block::LEN as u64).map_err(|_| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "image over 2 TB")
        })?;
        Ok(Self {
            file: RefCell::new(file),
            blocks,
            reads: Cell::new(0),
        })
    }
}

impl BlockDevice for FileBlockDevice {
    type Error = std::io::Error;

    fn read(&self, blocks: &mut [Block], start: BlockIdx) -> std::io::Result<()> {
        let mut f = self.file.borrow_mut();
        f.seek(SeekFrom::Start(start.into_bytes()))?;
        for b in blocks.iter_mut() {
            f.read_exact(&mut b.contents)?;
        }
        self.reads.set(self.reads.get() + blocks.len() as u64);
        Ok(())
    }

    fn write(&self, blocks: &[Block], start: BlockIdx) -> std::io::Result<()> {
        let mut f = self.file.borrow_mut();
        f.seek(SeekFrom::Start(start.into_bytes()))?;
        for b in blocks {
            f.write_all(&b.contents)?;
        }
        Ok(())
    }

    fn num_blocks(&self) -> std::io::Result<BlockCount> {
        Ok(BlockCount(self.blocks))
    }
}

/// The read-only clock, the core's (one definition for every board).
pub use pocketsplat_core::stream::sdmmc::NoClock;
