//! Just enough of a 32-bit little-endian ELF reader for the firmware: section sizes (what a board's
//! flash and RAM must hold, as `size -A` reports them) and symbol addresses (the marker functions an
//! instruction counter watches). Bounds-checked: a truncated or foreign file is an error naming the
//! file, never a panic.

use std::path::Path;

use anyhow::{bail, ensure, Context, Result};

/// `SHF_ALLOC`: the section occupies memory at run time.
const SHF_ALLOC: u32 = 0x2;
/// `SHT_NOBITS`: occupies memory but no file bytes (`.bss`).
const SHT_NOBITS: u32 = 8;
/// `SHT_SYMTAB`.
const SHT_SYMTAB: u32 = 2;

/// One section header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Section {
    /// Name (`.text`, `.bss`, …).
    pub name: String,
    /// Run-time address.
    pub addr: u32,
    /// Size, bytes.
    pub size: u32,
    /// Occupies memory at run time.
    pub alloc: bool,
    /// Has bytes in the file (loaded), i.e. not `.bss`-like.
    pub progbits: bool,
}

/// A parsed ELF file: its sections and its symbols.
#[derive(Clone, Debug)]
pub struct Elf {
    /// Sections in file order.
    pub sections: Vec<Section>,
    symbols: Vec<(String, u32)>,
}

use pocketsplat_core::bytes::le::{u16_at, u32_at};

fn cstr_at(b: &[u8], off: usize) -> Option<String> {
    let rest = b.get(off..)?;
    let end = rest.iter().position(|&c| c == 0)?;
    Some(String::from_utf8_lossy(&rest[..end]).into_owned())
}

impl Elf {
    /// Reads and parses `path`.
    ///
    /// # Errors
    /// When the file cannot be read or is not a well-formed 32-bit little-endian ELF file.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("{}", path.display()))?;
        Self::parse(&bytes)
            .with_context(|| format!("{}: not a readable ELF32 file", path.display()))
    }

    /// Parses an ELF32 little-endian image.
    ///
    /// # Errors
    /// When the header, a section header or the symbol table is truncated or inconsistent.
    pub fn parse(b: &[u8]) -> Result<Self> {
        ensure!(b.get(..4) == Some(b"\x7fELF"), "no ELF magic");
        ensure!(
            b.get(4) == Some(&1) && b.get(5) == Some(&1),
            "not 32-bit little-endian"
        );
        let short = || anyhow::anyhow!("truncated");
        let shoff = u32_at(b, 0x20).ok_or_else(short)? as usize;
        let shentsize = usize::from(u16_at(b, 0x2E).ok_or_else(short)?);
        let shnum = usize::from(u16_at(b, 0x30).ok_or_else(short)?);
        let shstrndx = usize::from(u16_at(b, 0x32).ok_or_else(short)?);
        ensure!(shentsize >= 40, "section header size {shentsize} below 40");
        ensure!(shstrndx < shnum, "section name table {shstrndx} of {shnum}");
        let header = |i: usize| -> Result<[u32; 10]> {
            let base = shoff + i * shentsize;
            let mut h = [0u32; 10];
            for (k, v) in h.iter_mut().enumerate() {
                *v = u32_at(b, base + 4 * k)
                    .ok_or_else(|| anyhow::anyhow!("section {i} truncated"))?;
            }
            Ok(h)
        };
        let headers: Vec<[u32; 10]> = (0..shnum).map(header).collect::<Result<_>>()?;
        let names_off = headers[shstrndx][4] as usize;
        let mut sections = Vec::with_capacity(shnum);
        let mut symbols = Vec::new();
        for h in &headers {
            let [name, kind, flags, addr, offset, size, link, _, _, entsize] = *h;
            let name = cstr_at(b, names_off + name as usize)
                .ok_or_else(|| anyhow::anyhow!("bad section name"))?;
            if kind == SHT_SYMTAB {
                let strtab = headers
                    .get(link as usize)
                    .ok_or_else(|| anyhow::anyhow!("symbol table links to section {link}"))?[4]
                    as usize;
                let entsize = entsize.max(16) as usize;
                let (start, end) = (offset as usize, offset as usize + size as usize);
                if b.len() < end {
                    bail!("symbol table truncated");
                }
                for sym in (start..end).step_by(entsize) {
                    let (Some(n), Some(value)) = (u32_at(b, sym), u32_at(b, sym + 4)) else {
                        bail!("symbol truncated");
                    };
                    if n != 0 {
                        if let Some(s) = cstr_at(b, strtab + n as usize) {
                            symbols.push((s, value));
                        }
                    }
                }
            }
            sections.push(Section {
                name,
                addr,
                size,
                alloc: flags & SHF_ALLOC != 0,
                progbits: kind != SHT_NOBITS,
            });
        }
        Ok(Elf { sections, symbols })
    }

    /// Address of the symbol `name` (for a Thumb function, with bit 0 set).
    pub fn symbol(&self, name: &str) -> Option<u32> {
        self.symbols
            .iter()
            .find_map(|(n, v)| (n == name).then_some(*v))
    }

    /// The run-time sections (`SHF_ALLOC`) whose address lies in `[start, end)`.
    pub fn alloc_in(&self, start: u32, end: u32) -> impl Iterator<Item = &Section> {
        self.sections
            .iter()
            .filter(move |s| s.alloc && s.size > 0 && (start..end).contains(&s.addr))
    }

    /// Memory use of a firmware linked with the workspace's memory.x: flash (code and read-only data
    /// below RAM, plus the initial values of `.data`), RAM (statics in `[ram, psram)`), PSRAM.
    pub fn memory(&self, ram: u32, psram: u32) -> Memory {
        let sum = |it: &mut dyn Iterator<Item = &Section>| it.map(|s| u64::from(s.size)).sum();
        let data: u64 = self
            .alloc_in(ram, psram)
            .filter(|s| s.progbits)
            .map(|s| u64::from(s.size))
            .sum();
        Memory {
            flash: sum(&mut self.alloc_in(0, ram)) + data,
            ram: sum(&mut self.alloc_in(ram, psram)),
            psram: sum(&mut self.alloc_in(psram, u32::MAX)),
        }
    }
}

/// Bytes of each memory a firmware image needs ([`Elf::memory`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Memory {
    /// Flash: code, read-only data, `.data`'s initial values.
    pub flash: u64,
    /// RAM: `.data`, `.bss`, `.uninit` (the stack comes on top).
    pub ram: u64,
    /// PSRAM: the linked-in model.
    pub psram: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32: null section, `.text` (alloc, 0x100 bytes at 0), `.bss` (alloc nobits at
    /// 0x2000_0000), `.symtab` with one symbol, `.strtab`, `.shstrtab`.
    fn tiny() -> Vec<u8> {
        let shstr = b"\0.text\0.bss\0.symtab\0.strtab\0.shstrtab\0".to_vec();
        let strtab = b"\0marker\0".to_vec();
        let mut sym = vec![0u8; 16]; // null symbol
        sym.extend(1u32.to_le_bytes());
        sym.extend(0x41u32.to_le_bytes());
        sym.extend([0u8; 8]);
        let mut b = vec![0u8; 52];
        b[..6].copy_from_slice(b"\x7fELF\x01\x01");
        let shstr_off = b.len();
        b.extend(&shstr);
        let str_off = b.len();
        b.extend(&strtab);
        let sym_off = b.len();
        b.extend(&sym);
        let shoff = b.len();
        let mut sh =
            |name: u32, kind: u32, flags: u32, addr: u32, off: usize, size: usize, link| {
                for v in [
                    name,
                    kind,
                    flags,
                    addr,
                    off as u32,
                    size as u32,
                    link,
                    0,
                    4,
                    16,
                ] {
                    b.extend(v.to_le_bytes());
                }
            };
        sh(0, 0, 0, 0, 0, 0, 0);
        sh(1, 1, SHF_ALLOC | 4, 0, 0, 0x100, 0);
        sh(7, SHT_NOBITS, SHF_ALLOC | 1, 0x2000_0000, 0, 0x40, 0);
        sh(12, SHT_SYMTAB, 0, 0, sym_off, sym.len(), 4);
        sh(20, 3, 0, 0, str_off, strtab.len(), 0);
        sh(28, 3, 0, 0, shstr_off, shstr.len(), 0);
        b[0x20..0x24].copy_from_slice(&(shoff as u32).to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        b[0x30..0x32].copy_from_slice(&6u16.to_le_bytes());
        b[0x32..0x34].copy_from_slice(&5u16.to_le_bytes());
        b
    }

    #[test]
    fn reads_sections_symbols_and_memory() {
        let elf = Elf::parse(&tiny()).unwrap();
        assert_eq!(elf.symbol("marker"), Some(0x41));
        assert_eq!(elf.symbol("other"), None);
        let names: Vec<_> = elf.sections.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            ["", ".text", ".bss", ".symtab", ".strtab", ".shstrtab"]
        );
        let m = elf.memory(0x2000_0000, 0x2100_0000);
        assert_eq!(
            m,
            Memory {
                flash: 0x100,
                ram: 0x40,
                psram: 0
            }
        );
    }

    #[test]
    fn truncated_or_foreign_files_are_errors() {
        let b = tiny();
        for cut in [0, 3, 40, b.len() - 1] {
            assert!(Elf::parse(&b[..cut]).is_err(), "cut at {cut}");
        }
        let mut wide = b.clone();
        wide[4] = 2;
        assert!(Elf::parse(&wide).is_err());
    }
}
