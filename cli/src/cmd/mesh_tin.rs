//! `relief mesh --method tin`: a greedy-insertion Delaunay TIN (Garland & Heckbert 1995, on
//! spade; crate `relief-tin`) written as OBJ, with its measured vertical error.
//!
//! A TIN has no separate preprocessing: its whole build is reported in `refine_ms`
//! (CONVENTIONS.md), and `preprocess_ms` is 0. `refine_cpu_ms` is the same build's on-CPU time
//! of the building thread (`CLOCK_THREAD_CPUTIME_ID`; `null` off Unix): on a loaded
//! machine it leaves out the time the thread waited for a core, which wall-clock `refine_ms`
//! does not.

use crate::{print_out, CliError, CliResult};
use relief_tin::{StopReason, Tin, TinOptions};
use std::path::Path;
use std::time::Instant;

/// Builds the TIN of `dem` until its vertical error is at most `max_error` (world z units) and/or
/// it has `max_vertices` vertices, whichever comes first (at least one must be given), writes it
/// to `out` as OBJ and prints statistics (one JSON object with `json`).
pub fn run_tin(
    dem: &relief_io::Dem,
    max_error: Option<f32>,
    max_vertices: Option<u32>,
    out: &Path,
    json: bool,
) -> CliResult {
    if max_error.is_none() && max_vertices.is_none() {
        return Err(CliError(
            "relief mesh --method tin needs --max-error E or --max-vertices N".into(),
        ));
    }
    let hf = dem.heightfield()?;
    // Without an error target the vertex budget alone decides: target 0 (exact).
    let mut options = TinOptions::default().with_max_error(max_error.unwrap_or(0.0));
    if let Some(n) = max_vertices {
        options = options.with_max_vertices(n);
    }
    options
        .validate()
        .map_err(|e| CliError(format!("invalid TIN options: {e}")))?;
    let cpu0 = thread_cpu_ns();
    let t0 = Instant::now();
    let tin = Tin::build(&hf, &options)?;
    let refine_ms = t0.elapsed().as_secs_f64() * 1e3;
    let refine_cpu_ms = match (cpu0, thread_cpu_ns()) {
        (Some(a), Some(b)) => Some(b.saturating_sub(a) as f64 * 1e-6),
        _ => None,
    };
    let t1 = Instant::now();
    let measured = tin.measure(&hf)?;
    let measure_ms = t1.elapsed().as_secs_f64() * 1e3;
    let t2 = Instant::now();
    relief_io::write_obj(out, &tin.positions(&hf), tin.triangles())?;
    let write_ms = t2.elapsed().as_secs_f64() * 1e3;
    let stop = match tin.stop_reason() {
        StopReason::ErrorReached => "error",
        StopReason::VertexBudget => "vertex-budget",
        StopReason::TriangleBudget => "triangle-budget",
    };
    if json {
        let v = serde_json::json!({
            "method": "tin",
            "width": dem.width,
            "height": dem.height,
            "max_error": max_error,
            "max_vertices": max_vertices,
            "vertices": tin.vertices().len(),
            "triangles": tin.triangles().len(),
            "max_error_measured": measured.max,
            "rms_error": measured.rms,
            "preprocess_ms": 0.0,
            "refine_ms": refine_ms,
            "refine_cpu_ms": refine_cpu_ms,
            "measure_ms": measure_ms,
            "write_ms": write_ms,
            "stop": stop,
            "out": out.display().to_string(),
        });
        print_out(&format!("{v}\n"))
    } else {
        print_out(&format!(
            "tin mesh of {w} x {h} samples -> {out}\n  vertices   {nv}\n  triangles  {nt}\n  max error  {me} (measured over all samples; target {target})\n  rms error  {rms}\n  stopped on {stop}\n  build      {refine_ms:.1} ms\n",
            w = dem.width,
            h = dem.height,
            out = out.display(),
            nv = tin.vertices().len(),
            nt = tin.triangles().len(),
            me = measured.max,
            target = max_error.map_or("none".to_string(), |e| e.to_string()),
            rms = measured.rms,
        ))
    }
}

/// Time the calling thread has spent on a CPU, in nanoseconds (user and kernel):
/// `clock_gettime(CLOCK_THREAD_CPUTIME_ID)`, exact to the call (unlike `/proc`'s schedstat, which
/// lags by up to a scheduler tick). `None` off Unix.
fn thread_cpu_ns() -> Option<u64> {
    #[cfg(unix)]
    {
        let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
        let ns = i128::from(t.tv_sec) * 1_000_000_000 + i128::from(t.tv_nsec);
        u64::try_from(ns).ok()
    }
    #[cfg(not(unix))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::run_tin;

    fn dem() -> relief_io::Dem {
        let (w, h) = (17u32, 11u32);
        let s = (0..w * h)
            .map(|i| ((i % w) as f32 * 0.7).sin() * 30.0 + (i / w) as f32)
            .collect();
        relief_io::Dem::new(w, h, s).unwrap()
    }

    fn obj_counts(p: &std::path::Path) -> (usize, usize) {
        let text = std::fs::read_to_string(p).unwrap();
        let v = text.lines().filter(|l| l.starts_with("v ")).count();
        let f = text.lines().filter(|l| l.starts_with("f ")).count();
        (v, f)
    }

    #[test]
    fn writes_an_obj_within_the_error_or_budget() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.obj");
        run_tin(&dem(), Some(2.0), None, &p, true).unwrap();
        let (v, f) = obj_counts(&p);
        let tin = relief_tin::Tin::build(
            &dem().heightfield().unwrap(),
            &relief_tin::TinOptions::default().with_max_error(2.0),
        )
        .unwrap();
        assert_eq!((v, f), (tin.vertices().len(), tin.triangles().len()));
        assert!(tin.max_error() <= 2.0);
        run_tin(&dem(), None, Some(9), &p, false).unwrap();
        assert_eq!(obj_counts(&p).0, 9);
    }

    #[test]
    fn rejects_missing_and_bad_targets() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.obj");
        assert!(run_tin(&dem(), None, None, &p, true).is_err());
        assert!(run_tin(&dem(), Some(f32::NAN), None, &p, true).is_err());
        assert!(run_tin(&dem(), Some(-1.0), None, &p, true).is_err());
        assert!(run_tin(&dem(), None, Some(3), &p, true).is_err());
        assert!(!p.exists());
    }
}
