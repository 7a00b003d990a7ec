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

/// Runs `f` on the file `name` in the root directory of the FAT volume of the disk image at
/// `image` (an MBR, then the volume), read through embedded-sdmmc: the simulator's SD card.
///
/// # Errors
/// When the image cannot be opened, has no FAT volume or no such file, or `f` fails.
pub fn with_file<R>(
    image: &Path,
    name: &str,
    f: impl FnOnce(
        &mut pocketsplat_core::stream::sdmmc::SdFile<'_, FileBlockDevice, NoClock, 4, 4, 1>,
    ) -> anyhow::Result<R>,
) -> anyhow::Result<R> {
    use anyhow::{anyhow, Context};
    let device = FileBlockDevice::open(image)
        .with_context(|| format!("cannot open the disk image {}", image.display()))?;
    let volumes: embedded_sdmmc::VolumeManager<_, _, 4, 4, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .map_err(|e| anyhow!("no FAT volume in its first partition: {e:?}"))?;
    let root = volumes
        .open_root_dir(volume)
        .map_err(|e| anyhow!("cannot open the root directory: {e:?}"))?;
    let handle = volumes
        .open_file_in_dir(root, name, embedded_sdmmc::Mode::ReadOnly)
        .map_err(|e| anyhow!("no file {name} in the root directory: {e:?}"))?;
    let mut sd = pocketsplat_core::stream::sdmmc::SdFile::new(&volumes, handle);
    let r = f(&mut sd);
    let _ = volumes.close_file(handle);
    let _ = volumes.close_dir(root);
    let _ = volumes.close_volume(volume);
    r
}
