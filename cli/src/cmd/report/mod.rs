//! `relief report`: what accuracy costs in time, on real terrain. Runs every available method on
//! one DEM and writes `index.html` (opens without a server), `report.md`, `report.json` and PNG
//! figures into the output folder. Every number is measured in the run that writes it.

mod diagrams;
mod effects;
mod mesh;
mod model;
mod plot;
mod rays;
mod render;
mod sections;

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use model::Section;
use relief_io::{Dem, Fill};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The bundled DEM, used when `--dem` is absent.
const BUNDLED: &str = "data/puget_sound_1k.png";

/// Options of `relief report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Elevation file (default: the bundled Puget Sound map with its 160 m spacing and 0.1 m
    /// units).
    #[arg(long, value_name = "PATH")]
    dem: Option<PathBuf>,
    /// Format of --dem (guessed when absent).
    #[arg(long, value_name = "F")]
    format: Option<String>,
    /// Column spacing of --dem in world units.
    #[arg(long, allow_negative_numbers = true)]
    dx: Option<f32>,
    /// Row spacing of --dem in world units.
    #[arg(long, allow_negative_numbers = true)]
    dy: Option<f32>,
    /// World units per stored height unit.
    #[arg(long, allow_negative_numbers = true)]
    z_scale: Option<f32>,
    /// Output folder (created; files in it are replaced atomically).
    #[arg(long, value_name = "DIR", default_value = "report")]
    out: PathBuf,
    /// A smaller run (a 257 x 257 crop, fewer parameters) that finishes in under a minute.
    #[arg(long)]
    quick: bool,
}

/// What every section gets: the DEM, the output folder and the mode.
pub struct Ctx<'a> {
    /// The DEM (cropped in quick mode).
    pub dem: &'a Dem,
    /// Output folder.
    pub out: &'a Path,
    /// Quick mode.
    pub quick: bool,
}

impl Ctx<'_> {
    /// Path of a figure file in the output folder.
    pub fn fig(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }
}

fn load(a: &ReportArgs) -> CliResult<(Dem, String)> {
    let (path, bundled) = match &a.dem {
        Some(p) => (p.clone(), false),
        None => {
            // From the repository root, or wherever this binary was built from.
            let here = PathBuf::from(BUNDLED);
            let built = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join(BUNDLED);
            (
                if here.exists() || !built.exists() {
                    here
                } else {
                    built
                },
                true,
            )
        }
    };
    if bundled && !path.exists() {
        return Err(CliError(format!(
            "{BUNDLED} not found: run from the repository root or pass --dem"
        )));
    }
    let format = match &a.format {
        Some(f) => Some(
            relief_io::Format::from_name(f)
                .ok_or_else(|| CliError(format!("unknown format '{f}'")))?,
        ),
        None => None,
    };
    let args = DemArgs {
        dem: path.clone(),
        format,
        width: None,
        height: None,
        nodata: None,
        fill: Fill::Error,
        dx: a.dx.or(bundled.then_some(160.0)),
        dy: a.dy.or(bundled.then_some(160.0)),
        z_scale: a.z_scale.or(bundled.then_some(0.1)),
        z_offset: None,
    };
    let (dem, _) = args.load()?;
    Ok((dem, path.display().to_string()))
}

/// A centred crop of at most `side x side` samples (the whole DEM when smaller).
fn crop(dem: &Dem, side: u32) -> Dem {
    if dem.width <= side && dem.height <= side {
        return dem.clone();
    }
    let (w, h) = (dem.width.min(side), dem.height.min(side));
    let (x0, y0) = ((dem.width - w) / 2, (dem.height - h) / 2);
    let mut samples = Vec::with_capacity((w * h) as usize);
    for y in y0..y0 + h {
        let row = (y * dem.width + x0) as usize;
        samples.extend_from_slice(&dem.samples[row..row + w as usize]);
    }
    Dem {
        width: w,
        height: h,
        samples,
        scale: dem.scale,
        nodata_count: dem.nodata_count,
    }
}

/// Runs `relief report`.
pub fn run(a: &ReportArgs) -> CliResult {
    let t_all = Instant::now();
    let (full, path) = load(a)?;
    let dem = if a.quick { crop(&full, 257) } else { full };
    // Everything is written into a fresh sibling folder and swapped in at the end, so a failed
    // or interrupted run never leaves a half-written report and never touches the previous one.
    let staging = Staging::new(&a.out)?;
    let ctx = Ctx {
        dem: &dem,
        out: &staging.dir,
        quick: a.quick,
    };
    type SectionFn = fn(&Ctx<'_>) -> CliResult<Section>;
    let plan: Vec<(&str, SectionFn)> = vec![
        ("terrain", sections::terrain),
        ("normals", sections::normals),
        ("mesh", mesh::mesh),
        ("rays", rays::rays),
        ("rbf", sections::rbf),
        ("effects", effects::effects),
        ("diagrams", diagrams::diagrams),
    ];
    let bar = ProgressBar::new(plan.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut done = Vec::new();
    for (name, f) in plan {
        bar.set_message(name.to_string());
        let t = Instant::now();
        let mut s = f(&ctx)?;
        s.seconds = t.elapsed().as_secs_f64();
        done.push(s);
        bar.inc(1);
    }
    bar.finish_and_clear();

    let title = format!(
        "relief report: {}",
        Path::new(&path)
            .file_name()
            .map_or(path.clone(), |n| n.to_string_lossy().into_owned())
    );
    let s = dem.scale;
    let preface = vec![
        format!(
            "DEM {path}{}: {} x {} samples, spacing {} x {}, z scale {}. Every number below was measured by this run of `relief report{}` on this machine ({} cores).",
            if a.quick { " (centre crop, --quick)" } else { "" },
            dem.width,
            dem.height,
            s.dx,
            s.dy,
            s.z_scale,
            if a.quick { " --quick" } else { "" },
            std::thread::available_parallelism().map_or(1, |n| n.get())
        ),
    ];
    let meta = serde_json::json!({
        "dem": path,
        "quick": a.quick,
        "width": dem.width,
        "height": dem.height,
        "dx": s.dx, "dy": s.dy, "z_scale": s.z_scale, "z_offset": s.z_offset,
        "total_s": t_all.elapsed().as_secs_f64(),
    });
    let md = render::markdown(&title, &preface, &done);
    let html = render::html(&title, &preface, &done);
    let json = render::json(meta, &done);
    let write = |name: &str, text: &str| -> CliResult {
        relief_io::write_atomic(&staging.dir.join(name), |w| w.write_all(text.as_bytes()))?;
        Ok(())
    };
    write("report.md", &md)?;
    write("report.json", &format!("{json:#}\n"))?;
    write("index.html", &html)?;
    staging.commit()?;

    let mut summary = format!("relief report -> {}\n", a.out.join("index.html").display());
    for s in &done {
        summary.push_str(&format!(
            "  {:<10} {:>7.1} s  {}\n",
            s.id, s.seconds, s.summary
        ));
    }
    summary.push_str(&format!(
        "  total      {:>7.1} s\n",
        t_all.elapsed().as_secs_f64()
    ));
    print_out(&summary)
}

/// A report folder under construction: `<out>.partial-<pid>` beside `out`, moved into place by
/// [`Staging::commit`] and removed if dropped uncommitted (a failed run). A run killed outright
/// leaves only the `.partial-` folder, which the next run removes.
struct Staging {
    dir: PathBuf,
    out: PathBuf,
    committed: bool,
}

impl Staging {
    fn new(out: &Path) -> CliResult<Staging> {
        let err = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
        let name = out
            .file_name()
            .ok_or_else(|| CliError(format!("{}: not a folder name", out.display())))?
            .to_string_lossy()
            .into_owned();
        let parent = match out.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(|e| err(&parent, e))?;
        if out.exists() && !out.is_dir() {
            return Err(CliError(format!(
                "{}: exists and is not a folder",
                out.display()
            )));
        }
        // Leftovers of killed runs.
        if let Ok(entries) = std::fs::read_dir(&parent) {
            for e in entries.flatten() {
                let n = e.file_name().to_string_lossy().into_owned();
                if n.starts_with(&format!(".{name}.partial-"))
                    || n.starts_with(&format!(".{name}.old-"))
                {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = parent.join(format!(".{name}.partial-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| err(&dir, e))?;
        Ok(Staging {
            dir,
            out: out.to_path_buf(),
            committed: false,
        })
    }

    /// Moves the finished report into place, replacing the previous one.
    fn commit(mut self) -> CliResult {
        let err = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
        let old = self.dir.with_file_name(format!(
            ".{}.old-{}",
            self.out
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            std::process::id()
        ));
        if self.out.exists() {
            std::fs::rename(&self.out, &old).map_err(|e| err(&self.out, e))?;
        }
        if let Err(e) = std::fs::rename(&self.dir, &self.out) {
            // Put the previous report back.
            let _ = std::fs::rename(&old, &self.out);
            return Err(err(&self.out, e));
        }
        self.committed = true;
        let _ = std::fs::remove_dir_all(&old);
        Ok(())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}
