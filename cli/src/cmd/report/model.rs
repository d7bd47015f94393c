//! What a report is made of: sections of text, tables and figures, plus their raw numbers.

use serde_json::Value;

/// A table of measured values.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// One line saying what the table shows.
    pub caption: String,
    /// Column headings.
    pub header: Vec<String>,
    /// Rows of formatted cells.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with a caption and headings.
    pub fn new(caption: &str, header: &[&str]) -> Table {
        Table {
            caption: caption.into(),
            header: header.iter().map(|h| (*h).to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }
}

/// A PNG figure written into the report folder.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name inside the report folder.
    pub file: String,
    /// What it shows.
    pub caption: String,
}

/// One section of the report.
#[derive(Debug, Clone)]
pub struct Section {
    /// Anchor and JSON key.
    pub id: String,
    /// Heading.
    pub title: String,
    /// Paragraphs (plain text, one per entry).
    pub text: Vec<String>,
    /// Tables.
    pub tables: Vec<Table>,
    /// Figures.
    pub figures: Vec<Figure>,
    /// The section's raw measurements for report.json.
    pub data: Value,
    /// One line for the terminal summary.
    pub summary: String,
    /// Seconds the section took to measure.
    pub seconds: f64,
}

impl Section {
    /// An empty section.
    pub fn new(id: &str, title: &str) -> Section {
        Section {
            id: id.into(),
            title: title.into(),
            text: Vec::new(),
            tables: Vec::new(),
            figures: Vec::new(),
            data: Value::Null,
            summary: String::new(),
            seconds: 0.0,
        }
    }
}

/// Formats a number with `d` decimals, or `-` when it is not finite.
pub fn num(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "-".into()
    }
}
