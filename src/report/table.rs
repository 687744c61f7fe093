//! The report's text: CSV and Markdown tables.

use std::fmt::Write as _;

/// One CSV field: quoted (with doubled quotes) when it holds a comma, quote or line break
/// (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// A CSV document: a header line and one line per row, every row as long as the header.
pub(super) fn csv(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = String::new();
    let line = |out: &mut String, cells: &mut dyn Iterator<Item = String>| {
        let cells: Vec<String> = cells.map(|c| csv_field(&c)).collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    };
    line(&mut out, &mut header.iter().map(|h| h.to_string()));
    for r in rows {
        assert_eq!(r.len(), header.len(), "CSV row length");
        line(&mut out, &mut r.iter().cloned());
    }
    out
}

/// A Markdown table.
pub(super) fn markdown(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "| {} |", header.join(" | "));
    let _ = writeln!(
        out,
        "|{}|",
        header.iter().map(|_| "---").collect::<Vec<_>>().join("|")
    );
    for r in rows {
        let cells: Vec<String> = r.iter().map(|c| c.replace('|', "\\|")).collect();
        let _ = writeln!(out, "| {} |", cells.join(" | "));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_only_what_needs_it() {
        let text = csv(
            &["a", "b,c"],
            &[
                vec!["1".into(), "say \"hi\"".into()],
                vec!["x\ny".into(), "".into()],
            ],
        );
        assert_eq!(text, "a,\"b,c\"\n1,\"say \"\"hi\"\"\"\n\"x\ny\",\n");
    }

    #[test]
    #[should_panic(expected = "CSV row length")]
    fn csv_refuses_ragged_rows() {
        csv(&["a", "b"], &[vec!["1".into()]]);
    }

    #[test]
    fn markdown_escapes_pipes() {
        let t = markdown(&["x", "y"], &[vec!["a|b".into(), "2".into()]]);
        assert_eq!(t, "| x | y |\n|---|---|\n| a\\|b | 2 |\n");
    }
}
