//! Standard base64 decoding (RFC 4648 alphabet, `=` padding optional), for data URLs such as the
//! `@pmndrs/assets` `*.exr.js` modules. Small enough that a dependency is not worth it.

/// Decodes base64 text; ASCII whitespace is skipped. Errors give the byte offset of the first bad character.
pub fn decode(text: &str) -> Result<Vec<u8>, String> {
    let body = text.trim_end_matches(|c: char| c == '=' || c.is_ascii_whitespace());
    let mut out = Vec::with_capacity(body.len() / 4 * 3 + 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for (i, c) in body.bytes().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        let v = sextet(c)
            .ok_or_else(|| format!("invalid base64 character {:?} at offset {i}", c as char))?;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("base64 text ends in the middle of a byte (its length is not valid)".into());
    }
    Ok(out)
}

/// The 6-bit value of one base64 character.
fn sextet(c: u8) -> Option<u32> {
    Some(match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    } as u32)
}

#[cfg(test)]
mod tests {
    use super::decode;

    #[test]
    fn decodes_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("Zg==", "f"),
            ("Zm8=", "fo"),
            ("Zm9v", "foo"),
            ("Zm9vYg==", "foob"),
            ("Zm9vYmE=", "fooba"),
            ("Zm9vYmFy", "foobar"),
        ];
        for (enc, dec) in cases {
            assert_eq!(decode(enc).unwrap(), dec.as_bytes(), "{enc}");
        }
        assert_eq!(decode("Zm9v\nYmFy").unwrap(), b"foobar");
    }

    #[test]
    fn rejects_bad_characters_and_lengths() {
        assert!(decode("Zm9v!").unwrap_err().contains("offset 4"));
        assert!(decode("Z").is_err());
    }
}
