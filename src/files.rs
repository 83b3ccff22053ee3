//! Reading the files a scene names (URDFs, OBJ meshes, the scene itself): regular files
//! only. A FIFO, a device or a socket at such a path would block the reader or stream
//! without end; it is refused by its kind before it is opened.

use std::io::{Error, ErrorKind};
use std::path::Path;

/// The text of the regular file at `path` (a symlink to one is followed); anything else is
/// refused with `ErrorKind::InvalidInput`, naming what it is.
pub fn read_regular(path: &Path) -> std::io::Result<String> {
    let kind = std::fs::metadata(path)?.file_type();
    if !kind.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("not a regular file but {}", describe(kind)),
        ));
    }
    std::fs::read_to_string(path)
}

fn describe(kind: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO";
        }
        if kind.is_char_device() || kind.is_block_device() {
            return "a device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if kind.is_dir() {
        "a directory"
    } else {
        "neither a file nor a directory"
    }
}

/// At most `max` characters of `text` for an error message, control characters escaped (a
/// line of a file quoted in a log cannot forge another log line) and the cut marked.
pub fn excerpt(text: &str, max: usize) -> String {
    let mut out: String = text
        .chars()
        .take(max)
        .flat_map(char::escape_default)
        .collect();
    if text.chars().nth(max).is_some() {
        out.push('…');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_is_refused_before_it_is_opened() {
        let dir = std::env::temp_dir().join(format!("dvrk-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("mesh.obj");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("SKIPPED: no mkfifo");
            return;
        }
        // Opening a FIFO with no writer would block: returning at all shows it was not.
        let e = read_regular(&fifo).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidInput);
        assert!(e.to_string().contains("a FIFO"), "{e}");
        let e = read_regular(&dir).unwrap_err();
        assert!(e.to_string().contains("a directory"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn excerpts_are_short_and_escaped() {
        assert_eq!(excerpt("abc", 5), "abc");
        assert_eq!(excerpt("abcdef", 3), "abc…");
        assert_eq!(excerpt("a\nb", 5), "a\\nb");
        assert_eq!(excerpt(&"x".repeat(1 << 20), 40).chars().count(), 41);
    }
}
