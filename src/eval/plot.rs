//! PNG figures of task-space paths and curves (plotters, bitmap backend, no fonts).
//!
//! A path figure is a grid of panels; each panel draws pairs of paths, for every arm
//! (consecutive blocks of `arm_dim` coordinates of the stacked task vector) projected on the
//! view's `(u, v)` axes: the nominal path in grey and the executed path in colour (blue,
//! red, green, … per arm), with equal axis scales. A curve figure draws polylines `y(x)` in
//! one chart. Figures carry no text: the caller's table says what each panel or colour is.

use std::path::Path;

use plotters::prelude::*;

/// One panel: pairs `(nominal, executed)` of stacked task paths, row-major `len × m`.
#[derive(Debug, Clone)]
pub struct PathPanel {
    /// Stacked task dimension `m` (a multiple of `arm_dim`).
    pub m: usize,
    /// Coordinates per arm (2 for `xy`, 3 for `xyz`).
    pub arm_dim: usize,
    /// Figure axes `(u, v)` in an arm's task frame (first `arm_dim` components used).
    pub view: [[f64; 3]; 2],
    /// `(nominal, executed)` path pairs (task units).
    pub paths: Vec<(Vec<f64>, Vec<f64>)>,
}

/// The planar view: `x` right, `y` up.
pub const XY_VIEW: [[f64; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

impl PathPanel {
    /// A panel with one nominal/executed pair.
    pub fn single(
        m: usize,
        arm_dim: usize,
        view: [[f64; 3]; 2],
        nominal: Vec<f64>,
        executed: Vec<f64>,
    ) -> Self {
        Self {
            m,
            arm_dim,
            view,
            paths: vec![(nominal, executed)],
        }
    }

    /// Projected points of arm `arm` of a stacked path (non-finite samples skipped).
    fn project(&self, data: &[f64], arm: usize) -> Vec<(f64, f64)> {
        let d = self.arm_dim;
        data.chunks_exact(self.m)
            .map(|r| {
                let p = &r[arm * d..(arm + 1) * d];
                let dot = |a: &[f64; 3]| p.iter().zip(a).map(|(x, y)| x * y).sum::<f64>();
                (dot(&self.view[0]), dot(&self.view[1]))
            })
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .collect()
    }
}

const ARM_COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

/// Writes `panels` side by side into a PNG at `path` (`size` pixels per panel side).
pub fn write_paths_png(path: &Path, panels: &[PathPanel], size: u32) -> Result<(), String> {
    write_paths_grid(path, panels, panels.len().max(1), size)
}

/// Writes `panels` into a PNG at `path`, `cols` panels per row (`size` pixels per panel).
pub fn write_paths_grid(
    path: &Path,
    panels: &[PathPanel],
    cols: usize,
    size: u32,
) -> Result<(), String> {
    if panels.is_empty() || cols == 0 {
        return Err("no panels to plot".into());
    }
    let rows = panels.len().div_ceil(cols);
    let root =
        BitMapBackend::new(path, (size * cols as u32, size * rows as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((rows, cols));
    for (area, p) in areas.iter().zip(panels) {
        if p.arm_dim == 0 || p.arm_dim > 3 || p.m == 0 || p.m % p.arm_dim != 0 {
            return Err(format!(
                "task dimension {} is not a stack of {}-D arms",
                p.m, p.arm_dim
            ));
        }
        let arms = p.m / p.arm_dim;
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (nom, exe) in &p.paths {
            for arm in 0..arms {
                for (a, b) in p.project(nom, arm).into_iter().chain(p.project(exe, arm)) {
                    x0 = x0.min(a);
                    x1 = x1.max(a);
                    y0 = y0.min(b);
                    y1 = y1.max(b);
                }
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
        for (nom, _) in &p.paths {
            for arm in 0..arms {
                chart
                    .draw_series(LineSeries::new(
                        p.project(nom, arm),
                        RGBColor(170, 170, 170).stroke_width(5),
                    ))
                    .map_err(|e| e.to_string())?;
            }
        }
        for (_, exe) in &p.paths {
            for arm in 0..arms {
                chart
                    .draw_series(LineSeries::new(
                        p.project(exe, arm),
                        ARM_COLOURS[arm % ARM_COLOURS.len()].stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

/// Colour `i` of a curve figure (a perceptually ordered ramp over `n` curves).
pub fn curve_colour(i: usize, n: usize) -> RGBColor {
    let t = if n <= 1 {
        0.0
    } else {
        i as f64 / (n - 1) as f64
    };
    // Dark blue → orange.
    let lerp = |a: f64, b: f64| (a + t * (b - a)).round() as u8;
    RGBColor(lerp(20.0, 240.0), lerp(50.0, 140.0), lerp(160.0, 20.0))
}

/// Writes polylines `y(x)` (colour `curve_colour(i, n)` for curve `i`) into one chart of
/// `width × height` pixels, with light grid lines at the `x` values of the first curve.
pub fn write_curves_png(
    path: &Path,
    curves: &[Vec<(f64, f64)>],
    width: u32,
    height: u32,
) -> Result<(), String> {
    let pts = curves
        .iter()
        .flatten()
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y1) = (f64::MAX, f64::MIN, 0.0f64);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    if x0 >= x1 {
        return Err("curves have no finite extent".into());
    }
    let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .build_cartesian_2d(x0..x1, 0.0..(y1 * 1.05).max(1e-9))
        .map_err(|e| e.to_string())?;
    if let Some(first) = curves.first() {
        for &(x, _) in first {
            chart
                .draw_series(LineSeries::new(
                    [(x, 0.0), (x, y1 * 1.05)],
                    RGBColor(225, 225, 225),
                ))
                .map_err(|e| e.to_string())?;
        }
    }
    for (i, c) in curves.iter().enumerate() {
        chart
            .draw_series(LineSeries::new(
                c.iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite()),
                curve_colour(i, curves.len()).stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}
