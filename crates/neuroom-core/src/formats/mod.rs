//! The on-disk formats of FORMAT.md.
