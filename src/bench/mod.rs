//! Benchmark suites behind `hardbody bench`.

pub mod compress;
pub mod edmd;
pub mod edmd_speed;
pub mod effects;
pub mod jam;
pub mod mc;
pub mod ocsi;
pub mod plot;
pub mod scene;
pub mod speed_plots;

/// A Markdown table: a header of `columns`, its rule, and one line per
/// row, each row given as its cells.
pub fn markdown_table(columns: &[&str], rows: impl IntoIterator<Item = Vec<String>>) -> String {
    let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
    let mut out = line(&columns.iter().map(|c| c.to_string()).collect::<Vec<_>>());
    out += &line(&vec!["---".to_string(); columns.len()]).replace(' ', "");
    for row in rows {
        out += &line(&row);
    }
    out
}
