//! Several files as one zip (PKZIP APPNOTE 6.3, written by the `zip` crate with Deflate), so
//! the page downloads a tiled or multi-file export in one step.

use std::io::{Cursor, Write as _};

use super::File;
use crate::jobs::JobCtx;

/// `files` in one zip archive, in their order.
pub fn zip(files: &[File]) -> Result<Vec<u8>, String> {
    crate::jobs::run_inline(|ctx| async move { zip_in(files, &ctx).await })
}

/// Bytes compressed between two ticks of [`zip_in`] (a few milliseconds of Deflate).
const BYTES_PER_TICK: usize = 1 << 18;

/// [`zip`] in a job: each file is compressed [`BYTES_PER_TICK`] at a time with a tick
/// after each piece, so a large archive does not hold the page.
pub async fn zip_in(files: &[File], ctx: &JobCtx) -> Result<Vec<u8>, String> {
    let total: usize = files.iter().map(|f| f.bytes.len()).sum();
    let mut writer = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .large_file(total > u32::MAX as usize / 2);
    let mut done = 0;
    for file in files {
        writer
            .start_file(file.name.as_str(), options)
            .map_err(|e| format!("zip: {e}"))?;
        for piece in file.bytes.chunks(BYTES_PER_TICK) {
            ctx.tick_of(done, total, "zipping the files")
                .await
                .map_err(|_| "cancelled".to_owned())?;
            writer.write_all(piece).map_err(|e| format!("zip: {e}"))?;
            done += piece.len();
        }
    }
    let cursor = writer.finish().map_err(|e| format!("zip: {e}"))?;
    Ok(cursor.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read as _;

    #[test]
    fn files_come_back_out_of_the_zip() {
        let files = vec![
            File {
                name: "a.png".into(),
                mime: "image/png",
                bytes: vec![1, 2, 3],
            },
            File {
                name: "b.json".into(),
                mime: "application/json",
                bytes: b"{}".repeat(1000),
            },
        ];
        let bytes = zip(&files).unwrap();
        let mut archive = zip::ZipArchive::new(Cursor::new(bytes)).unwrap();
        assert_eq!(archive.len(), 2);
        for f in &files {
            let mut back = Vec::new();
            archive
                .by_name(&f.name)
                .unwrap()
                .read_to_end(&mut back)
                .unwrap();
            assert_eq!(back, f.bytes);
        }
    }
}
