//! The other text the host program reads: point-match files of
//! `host-sim homography` and the command-line number parsers. (There is no
//! TUM reader: TUM files are only written.)
#![no_main]

use host_sim::cli::{parse_numbers, parse_threshold};
use host_sim::matches::parse_matches;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_matches(Path::new("matches.txt"), text) {
        Ok(ms) => {
            assert!(ms.len() <= text.lines().count());
            for m in ms {
                assert!(m.p1.iter().chain(&m.p2).all(|v| v.is_finite()));
            }
        }
        Err(e) => {
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().starts_with("matches.txt:"), "{e}");
        }
    }
    if let Ok(v) = parse_numbers::<4>(text) {
        assert!(v.iter().all(|x| x.is_finite()));
    }
    if let Ok(v) = parse_numbers::<9>(text) {
        assert!(v.iter().all(|x| x.is_finite()));
    }
    if let Ok(t) = parse_threshold(text) {
        assert!(t.is_finite() && t > 0.0);
    }
});
