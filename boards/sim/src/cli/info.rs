//! `pocketsplat info FILE [--json]`: what a point file or scene pack holds.

use std::path::PathBuf;

use anyhow::Result;

/// The arguments of `info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The file.
    file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

impl InfoArgs {
    /// The file the command reads (what its errors name).
    pub fn input(&self) -> &std::path::Path {
        &self.file
    }
}

/// The `info` command.
///
/// # Errors
/// When the file cannot be read or is invalid.
pub fn run(args: &InfoArgs) -> Result<()> {
    let info = pocketsplat_sim::info::describe(&args.file)?;
    if args.json {
        println!("{}", info.to_json()?);
    } else {
        print!("{}", info.to_text(&args.file));
    }
    Ok(())
}
