//! Several files as one zip (PKZIP APPNOTE 6.3, written by the `zip` crate with Deflate), so
//! the page downloads a tiled or multi-file export in one step.

use std::io::{Cursor, Write as _};

use super::File;

/// `files` in one zip archive, in their order.
pub fn zip(files: &[File]) -> Result<Vec<u8>, String> {
    let mut writer = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .large_file(files.iter().map(|f| f.bytes.len()).sum::<usize>() > u32::MAX as usize / 2);
    for file in files {
        writer
            .start_file(file.name.as_str(), options)
            .map_err(|e| format!("zip: {e}"))?;
        writer
            .write_all(&file.bytes)
            .map_err(|e| format!("zip: {e}"))?;
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
