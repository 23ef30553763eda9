//! `luxnode bench table1` reproduces the CAD vs RGBD rows of docs/accuracy.md: the binary is
//! run as a person runs it, and every figure it prints must match the document within its
//! rounding plus a tenth of the value.

use std::path::Path;
use std::process::Command;

/// The figures of a table line: the cells that end in " %".
fn percents(line: &str) -> Vec<f64> {
    line.split('|')
        .filter_map(|c| c.trim().strip_suffix(" %"))
        .filter_map(|c| c.trim().parse().ok())
        .collect()
}

/// The first four cells, which name the row.
fn key(line: &str) -> String {
    line.split('|')
        .skip(1)
        .take(4)
        .map(|c| c.trim().trim_end_matches(" (default)"))
        .collect::<Vec<_>>()
        .join("|")
}

#[test]
fn bench_table1_reproduces_docs_accuracy() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/accuracy.md")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(["bench", "table1", "--scene"])
        .arg(root.join("reference/scenes/office_a"))
        .output()
        .expect("luxnode bench table1");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("| RGBD") || l.starts_with("| CAD clipped"))
        .collect();
    assert_eq!(rows.len(), 10, "{text}");
    for r in rows {
        let k = key(r);
        let documented = doc
            .lines()
            .find(|l| l.starts_with('|') && key(l) == k)
            .unwrap_or_else(|| panic!("docs/accuracy.md has no row {k:?}"));
        let (got, want) = (percents(r), percents(documented));
        assert_eq!(got.len(), 3, "{r}");
        assert_eq!(want.len(), 3, "{documented}");
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g - w).abs() <= 0.005 + 0.1 * w,
                "{k}: measured {r}\ndocs/accuracy.md {documented}"
            );
        }
    }
}

#[test]
fn the_row_readers_read_what_they_must() {
    let l = "| RGBD | noisy | on | estimated, median (default) | 4.36 % | 3.92 % | 7.44 % |";
    assert_eq!(percents(l), vec![4.36, 3.92, 7.44]);
    assert_eq!(key(l), "RGBD|noisy|on|estimated, median");
}
