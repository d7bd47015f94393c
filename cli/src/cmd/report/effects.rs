//! The report's effects section: what each effect a scene can name costs, as a ratio to the bare
//! frame, measured on the GPU adapter when one exists (lavapipe in CI) and on the CPU backend
//! otherwise. Frames are rendered round-robin (one frame of each scene per round) so that load on
//! a shared machine hits every scene alike, and each scene reports its median frame time.

use super::model::{num, Section, Table};
use super::rays::camera;
use super::Ctx;
use crate::cmd::render::render_cpu;
use crate::CliResult;
use relief_wgpu::{headless, Effect, Method, Renderer, Scene};
use serde_json::json;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The section.
pub fn effects(ctx: &Ctx<'_>) -> CliResult<Section> {
    let hf = ctx.dem.heightfield()?;
    let (w, h) = if ctx.quick { (320, 180) } else { (640, 360) };
    let rounds = if ctx.quick { 5 } else { 15 };
    let cam = camera(&hf, w, h)?;
    let mut s = Section::new("effects", "Effects on demand: what each one costs");
    let mut t = Table::new(
        "Frame time of each scene against the bare frame (median over round-robin rounds)",
        &[
            "scene",
            "passes per frame",
            "frame ms",
            "vs bare frame",
            "CPU recording ms",
        ],
    );
    let mut rows = Vec::new();
    match headless() {
        Ok(gpu) => {
            let mut scenes: Vec<(String, Renderer)> = Vec::new();
            let mut add = |name: &str, scene: Scene| -> CliResult {
                scenes.push((
                    name.to_string(),
                    Renderer::new(&gpu.device, &gpu.queue, &hf, scene)?,
                ));
                Ok(())
            };
            add("bare (maxmip)", Scene::new())?;
            for e in Effect::ALL {
                add(e.name(), Scene::new().with_effect(e))?;
            }
            add(
                "lighting + shadows + fog",
                Scene::new().with_effects(&[Effect::Lighting, Effect::Shadows, Effect::Fog]),
            )?;
            add(
                "march instead of maxmip",
                Scene::new().with_method(Method::march()),
            )?;
            for (_, r) in scenes.iter_mut() {
                r.render(&gpu.device, &gpu.queue, &cam)?;
            }
            let mut times = vec![Vec::new(); scenes.len()];
            let mut record = vec![Vec::new(); scenes.len()];
            let mut passes = vec![String::new(); scenes.len()];
            for _ in 0..rounds {
                for (k, (_, r)) in scenes.iter_mut().enumerate() {
                    let (_, p) = r.render_profiled(&gpu.device, &gpu.queue, &cam)?;
                    times[k].push(p.iter().map(|x| x.ms).sum::<f64>());
                    record[k].push(p.iter().map(|x| x.cpu_ms).sum::<f64>());
                    passes[k] = p
                        .iter()
                        .map(|x| x.pass.as_str())
                        .collect::<Vec<_>>()
                        .join(", ");
                }
            }
            let meds: Vec<f64> = times.into_iter().map(median).collect();
            let recs: Vec<f64> = record.into_iter().map(median).collect();
            for (k, (name, _)) in scenes.iter().enumerate() {
                t.row(vec![
                    name.clone(),
                    passes[k].clone(),
                    num(meds[k], 2),
                    format!("{:.2}x", meds[k] / meds[0]),
                    num(recs[k], 3),
                ]);
                rows.push(json!({"scene": name, "passes": passes[k], "ms": meds[k], "ratio": meds[k] / meds[0], "record_ms": recs[k]}));
            }
            let clock = match scenes.first().map(|s| s.1.clock()) {
                Some(relief_wgpu::Clock::Gpu) => {
                    "Times are GPU timestamps between the passes of one submission."
                }
                _ => "Times are wall-clock per pass, submitted and waited for (no GPU timestamps on this adapter).",
            };
            let clock = format!("{clock} CPU recording: the CPU's own time per frame for the passes' queue writes, CPU-side work and command recording (part of the frame time on the wall clock, beside it with GPU timestamps).");
            s.text.push(format!(
                "GPU backend on {} ({:?}), {w} x {h} pixels, {rounds} rounds. A scene names its effects; only the passes and shader variants they need are built and dispatched (the pass list is exact: tests assert it). {clock}",
                gpu.info.name, gpu.info.backend
            ));
            s.summary = format!(
                "gpu: shadows {:.2}x bare",
                rows.iter()
                    .find(|r| r["scene"] == "shadows")
                    .and_then(|r| r["ratio"].as_f64())
                    .unwrap_or(f64::NAN)
            );
        }
        Err(e) => {
            let scenes: [(&str, &[Effect]); 5] = [
                ("bare (maxmip)", &[]),
                ("lighting", &[Effect::Lighting]),
                ("shadows", &[Effect::Shadows]),
                ("fog", &[Effect::Fog]),
                (
                    "lighting + shadows + fog",
                    &[Effect::Lighting, Effect::Shadows, Effect::Fog],
                ),
            ];
            let mut times = vec![Vec::new(); scenes.len()];
            let mut passes = vec![String::new(); scenes.len()];
            for _ in 0..rounds.min(5) {
                for (k, (_, fx)) in scenes.iter().enumerate() {
                    let t0 = Instant::now();
                    let r = render_cpu(&hf, &cam, false, fx, None)?;
                    times[k].push(t0.elapsed().as_secs_f64() * 1e3);
                    passes[k] = r
                        .passes
                        .iter()
                        .map(|p| p.0.as_str())
                        .collect::<Vec<_>>()
                        .join(", ");
                }
            }
            let meds: Vec<f64> = times.into_iter().map(median).collect();
            for (k, (name, _)) in scenes.iter().enumerate() {
                t.row(vec![
                    (*name).into(),
                    passes[k].clone(),
                    num(meds[k], 2),
                    format!("{:.2}x", meds[k] / meds[0]),
                    "-".into(),
                ]);
                rows.push(json!({"scene": name, "passes": passes[k], "ms": meds[k], "ratio": meds[k] / meds[0]}));
            }
            s.text.push(format!(
                "No GPU adapter ({e}): the CPU backend of `relief render` stands in, which renders lighting, shadows and fog only. {w} x {h} pixels, rows in parallel, each frame including its max-mip build."
            ));
            s.summary = "cpu fallback".into();
        }
    }
    s.tables.push(t);
    s.data = json!({"width": w, "height": h, "rounds": rounds, "scenes": rows});
    Ok(s)
}
