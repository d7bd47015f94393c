//! Writes a report as Markdown, self-contained HTML (no server needed: figures are relative
//! files) and JSON.

use super::model::{Section, Table};
use serde_json::{json, Value};

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn md_table(t: &Table, out: &mut String) {
    out.push_str(&format!("*{}*\n\n", t.caption));
    out.push_str(&format!("| {} |\n", t.header.join(" | ")));
    out.push_str(&format!("|{}\n", "---|".repeat(t.header.len())));
    for r in &t.rows {
        out.push_str(&format!("| {} |\n", r.join(" | ")));
    }
    out.push('\n');
}

/// The Markdown report.
pub fn markdown(title: &str, preface: &[String], sections: &[Section]) -> String {
    let mut out = format!("# {title}\n\n");
    for p in preface {
        out.push_str(&format!("{p}\n\n"));
    }
    for s in sections {
        out.push_str(&format!("## {}\n\n", s.title));
        for p in &s.text {
            out.push_str(&format!("{p}\n\n"));
        }
        for t in &s.tables {
            md_table(t, &mut out);
        }
        for f in &s.figures {
            out.push_str(&format!(
                "![{}]({})\n\n*{}*\n\n",
                f.caption, f.file, f.caption
            ));
        }
    }
    out
}

/// The HTML report: one page, figures as relative `<img>` files.
pub fn html(title: &str, preface: &[String], sections: &[Section]) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n\
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}}\
table{{border-collapse:collapse;margin:0.5em 0 1.5em}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}\
th{{background:#eee}}caption{{text-align:left;font-style:italic;padding:4px 0}}figure{{display:inline-block;margin:0.5em 1em 1em 0}}\
figure img{{max-width:520px;border:1px solid #ccc}}figcaption{{font-size:90%;max-width:520px}}nav a{{margin-right:1em}}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
        esc(title),
        esc(title)
    ));
    out.push_str("<nav>");
    for s in sections {
        out.push_str(&format!(
            "<a href=\"#{}\">{}</a>",
            esc(&s.id),
            esc(&s.title)
        ));
    }
    out.push_str("</nav>\n");
    for p in preface {
        out.push_str(&format!("<p>{}</p>\n", esc(p)));
    }
    for s in sections {
        out.push_str(&format!(
            "<section id=\"{}\">\n<h2>{}</h2>\n",
            esc(&s.id),
            esc(&s.title)
        ));
        for p in &s.text {
            out.push_str(&format!("<p>{}</p>\n", esc(p)));
        }
        for t in &s.tables {
            out.push_str(&format!(
                "<table>\n<caption>{}</caption>\n<tr>",
                esc(&t.caption)
            ));
            for h in &t.header {
                out.push_str(&format!("<th>{}</th>", esc(h)));
            }
            out.push_str("</tr>\n");
            for r in &t.rows {
                out.push_str("<tr>");
                for c in r {
                    out.push_str(&format!("<td>{}</td>", esc(c)));
                }
                out.push_str("</tr>\n");
            }
            out.push_str("</table>\n");
        }
        for f in &s.figures {
            out.push_str(&format!(
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
                esc(&f.file),
                esc(&f.caption),
                esc(&f.caption)
            ));
        }
        out.push_str("</section>\n");
    }
    // Marks the page with how many figures loaded, so a headless browser (and a reader) can
    // tell a broken figure at once.
    out.push_str(
        "<script>window.addEventListener('load',function(){var im=Array.prototype.slice.call(document.images);\
var ok=im.filter(function(i){return i.complete&&i.naturalWidth>0;});\
document.body.setAttribute('data-images-total',im.length);document.body.setAttribute('data-images-ok',ok.length);\
im.forEach(function(i){if(ok.indexOf(i)<0){i.style.outline='4px solid red';}});});</script>\n",
    );
    out.push_str("</body>\n</html>\n");
    out
}

/// The JSON report: run metadata plus each section's data, tables and figure files.
pub fn json(meta: Value, sections: &[Section]) -> Value {
    let mut secs = serde_json::Map::new();
    for s in sections {
        secs.insert(
            s.id.clone(),
            json!({
                "title": s.title,
                "data": s.data,
                "tables": s.tables.iter().map(|t| json!({"caption": t.caption, "header": t.header, "rows": t.rows})).collect::<Vec<_>>(),
                "figures": s.figures.iter().map(|f| json!({"file": f.file, "caption": f.caption})).collect::<Vec<_>>(),
            }),
        );
    }
    json!({ "meta": meta, "sections": secs })
}
