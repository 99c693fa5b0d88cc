//! PNG figures of planar task-space paths (plotters, bitmap backend, no fonts).
//!
//! A figure is a row of panels; each panel draws, for every arm (consecutive `xy` pairs of
//! the stacked task vector), the nominal path in grey and the executed path in colour
//! (blue, red, green, … per arm), with equal axis scales. Panels carry no text: the
//! caller's table says which condition each panel shows, in order.

use std::path::Path;

use plotters::prelude::*;

/// One panel: stacked task paths, row-major `len × m` (task units, `m` even: `xy` per arm).
#[derive(Debug, Clone)]
pub struct PathPanel {
    /// Task dimension `m` (2 per arm).
    pub m: usize,
    /// Nominal path.
    pub nominal: Vec<f64>,
    /// Executed path.
    pub executed: Vec<f64>,
}

const ARM_COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

/// Writes `panels` side by side into a PNG at `path` (`size` pixels per panel side).
pub fn write_paths_png(path: &Path, panels: &[PathPanel], size: u32) -> Result<(), String> {
    if panels.is_empty() {
        return Err("no panels to plot".into());
    }
    let root = BitMapBackend::new(path, (size * panels.len() as u32, size)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((1, panels.len()));
    for (area, p) in areas.iter().zip(panels) {
        if p.m == 0 || p.m % 2 != 0 {
            return Err(format!("task dimension {} is not a stack of xy pairs", p.m));
        }
        let pts = p.nominal.iter().chain(&p.executed).copied();
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (i, v) in pts.enumerate() {
            if !v.is_finite() {
                continue;
            }
            if i % 2 == 0 {
                x0 = x0.min(v);
                x1 = x1.max(v);
            } else {
                y0 = y0.min(v);
                y1 = y1.max(v);
            }
        }
        if x0 > x1 || y0 > y1 {
            return Err("panel has no finite points".into());
        }
        // Equal scales, 5 % margin.
        let span = (x1 - x0).max(y1 - y0).max(1e-9) * 1.1;
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let mut chart = ChartBuilder::on(area)
            .margin(8)
            .build_cartesian_2d(
                (cx - span / 2.0)..(cx + span / 2.0),
                (cy - span / 2.0)..(cy + span / 2.0),
            )
            .map_err(|e| e.to_string())?;
        chart
            .plotting_area()
            .draw(&Rectangle::new(
                [
                    (cx - span / 2.0, cy - span / 2.0),
                    (cx + span / 2.0, cy + span / 2.0),
                ],
                BLACK.mix(0.3),
            ))
            .map_err(|e| e.to_string())?;
        for arm in 0..p.m / 2 {
            let series = |data: &[f64]| -> Vec<(f64, f64)> {
                data.chunks_exact(p.m)
                    .map(|r| (r[2 * arm], r[2 * arm + 1]))
                    .filter(|(a, b)| a.is_finite() && b.is_finite())
                    .collect()
            };
            chart
                .draw_series(LineSeries::new(
                    series(&p.nominal),
                    RGBColor(170, 170, 170).stroke_width(5),
                ))
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(LineSeries::new(
                    series(&p.executed),
                    ARM_COLOURS[arm % ARM_COLOURS.len()].stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
        }
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}
