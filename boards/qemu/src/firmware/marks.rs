//! Markers for an instruction counter: one function per [`Phase`], each passing a different
//! constant through `black_box`, so that LTO can neither delete the calls (an empty function has
//! no effect) nor fold the five into one address. The plugin finds them by name in the ELF.

use pocketsplat_qemu::Phase;

macro_rules! marker {
    ($name:ident, $value:expr) => {
        #[no_mangle]
        #[inline(never)]
        extern "C" fn $name() {
            core::hint::black_box($value);
        }
    };
}
marker!(pocketsplat_mark_setup, 1u32);
marker!(pocketsplat_mark_table, 2u32);
marker!(pocketsplat_mark_clear, 3u32);
marker!(pocketsplat_mark_traverse, 4u32);
marker!(pocketsplat_mark_end, 5u32);

/// Calls the marker of `phase`.
pub fn hit(phase: Phase) {
    match phase {
        Phase::Setup => pocketsplat_mark_setup(),
        Phase::Table => pocketsplat_mark_table(),
        Phase::Clear => pocketsplat_mark_clear(),
        Phase::Traverse => pocketsplat_mark_traverse(),
        Phase::End => pocketsplat_mark_end(),
    }
}
