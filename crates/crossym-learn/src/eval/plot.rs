//! PNG figures of task-space paths and curves that explain themselves (plotters, bitmap
//! backend, an embedded DejaVu Sans so no system font is needed).
//!
//! A path figure is a title, a legend strip and a grid of panels; each panel carries its
//! own label (a condition `θ / λ / σ`, a test set) and draws pairs of paths, for every arm
//! (consecutive blocks of `arm_dim` coordinates of the stacked task vector) projected on the
//! view's `(u, v)` axes: `(p·u, p·v)` for an arm's task point `p`. The nominal path is grey,
//! the executed path coloured per arm (blue, red, green, …), the axes equally scaled, ticked
//! and named after the view (`x`, `−y`, …) with the figure's units. A curve figure draws
//! named polylines `y(x)` in one chart with a title, axis names and a legend.
//!
//! Text is drawn with DejaVu Sans (Bitstream Vera licence, `crates/crossym-learn/assets/fonts/LICENSE`), compiled
//! into the binary and registered with plotters' pure-Rust `ab_glyph` renderer on first use.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor;

use crossym_math::symmetry::compose::Condition;

/// The embedded font (DejaVu Sans 2.37, Bitstream Vera licence).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The font family every figure uses (registered as plotters' `sans-serif`).
const FAMILY: &str = "sans-serif";

/// Registers the embedded font once; an error names what failed.
fn ensure_font() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .map_err(|_| "the embedded font DejaVuSans.ttf is not a valid TrueType font".into())
    })
    .clone()
}

/// One panel: a label and pairs `(nominal, executed)` of stacked task paths, row-major
/// `len × m`.
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
    /// Caption above the panel (the condition, the test set; empty → none).
    pub label: String,
}

/// The planar view: `x` right, `y` up.
pub const XY_VIEW: [[f64; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

impl PathPanel {
    /// A panel with one nominal/executed pair and a caption.
    pub fn single(
        m: usize,
        arm_dim: usize,
        view: [[f64; 3]; 2],
        nominal: Vec<f64>,
        executed: Vec<f64>,
        label: impl Into<String>,
    ) -> Self {
        Self {
            m,
            arm_dim,
            view,
            paths: vec![(nominal, executed)],
            label: label.into(),
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

    /// The panel's bounding box `(u0, u1, v0, v1)` over every path and arm, `None` without a
    /// finite point.
    fn bounds(&self) -> Option<(f64, f64, f64, f64)> {
        let arms = self.m / self.arm_dim;
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (nom, exe) in &self.paths {
            for arm in 0..arms {
                for (a, b) in self
                    .project(nom, arm)
                    .into_iter()
                    .chain(self.project(exe, arm))
                {
                    x0 = x0.min(a);
                    x1 = x1.max(a);
                    y0 = y0.min(b);
                    y1 = y1.max(b);
                }
            }
        }
        (x0 <= x1 && y0 <= y1).then_some((x0, x1, y0, y1))
    }
}

/// The words of a path figure.
#[derive(Debug, Clone, Default)]
pub struct PathFigure {
    /// Title across the top (what was run, on which robot / task).
    pub title: String,
    /// Unit of the task coordinates on the axes (`m`, `task units`).
    pub units: String,
    /// Legend name of each arm, in stacking order (missing → `arm i`).
    pub arm_names: Vec<String>,
    /// Legend name of the grey paths (empty → `nominal`).
    pub nominal_name: String,
    /// Legend name of the coloured paths (empty → `executed`).
    pub executed_name: String,
}

impl PathFigure {
    /// A figure titled `title` for `kin`'s arms (legend `<chain> arm`) in `eval`'s units.
    pub fn for_robot(
        title: impl Into<String>,
        kin: &crossym_math::kinematics::Kinematics,
        eval: &super::EvalConfig,
    ) -> Self {
        Self {
            title: title.into(),
            units: eval.units.clone(),
            arm_names: kin
                .chains()
                .iter()
                .map(|c| format!("{} arm", c.name))
                .collect(),
            ..Default::default()
        }
    }
}

/// The name of a view axis `a` over an arm's `d` task coordinates: `x`, `−y`, or a
/// combination such as `0.5x + 0.87z`.
pub fn axis_name(a: &[f64; 3], d: usize) -> String {
    const NAMES: [&str; 3] = ["x", "y", "z"];
    let terms: Vec<(usize, f64)> = a[..d.min(3)]
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, c)| c.abs() > 1e-9)
        .collect();
    match terms.as_slice() {
        [] => "0".into(),
        [(i, c)] if (c.abs() - 1.0).abs() < 1e-9 => {
            format!("{}{}", if *c < 0.0 { "−" } else { "" }, NAMES[*i])
        }
        _ => {
            let mut s = String::new();
            for (k, (i, c)) in terms.iter().enumerate() {
                let sign = if *c < 0.0 { "−" } else { "+" };
                if k == 0 {
                    if *c < 0.0 {
                        s.push('−');
                    }
                } else {
                    s.push_str(&format!(" {sign} "));
                }
                let m = c.abs();
                if (m - 1.0).abs() > 1e-9 {
                    s.push_str(&format!("{}", (m * 100.0).round() / 100.0));
                }
                s.push_str(NAMES[*i]);
            }
            s
        }
    }
}

/// A condition as a caption: `θ = 45°, λ = 1.2, σ = −1`.
pub fn condition_label(c: &Condition) -> String {
    let theta = c.theta.to_degrees();
    let theta = if (theta - theta.round()).abs() < 1e-6 {
        format!("{}", theta.round())
    } else {
        format!("{theta:.1}")
    };
    let sigma = if c.reflection < 0 { "−1" } else { "+1" };
    format!(
        "θ = {}°, λ = {}, σ = {sigma}",
        theta.replace('-', "−"),
        (c.scale * 1000.0).round() / 1000.0
    )
}

/// Colour of arm `i`'s executed path.
pub fn arm_colour(i: usize) -> RGBColor {
    ARM_COLOURS[i % ARM_COLOURS.len()]
}

const ARM_COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];
const NOMINAL: RGBColor = RGBColor(170, 170, 170);
const TITLE_PX: u32 = 38;
const LEGEND_PX: u32 = 26;
const MARGIN: u32 = 8;
const X_LABEL_PX: u32 = 40;
const Y_LABEL_PX: u32 = 56;

/// `v` with `d` decimals and a typographic minus (no `−0`).
fn fixed(v: f64, d: usize) -> String {
    let t = format!("{v:.d$}");
    let zero = t
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.');
    if zero {
        t.trim_start_matches('-').to_string()
    } else {
        t.replace('-', "−")
    }
}

/// A tick value on an axis spanning `span`: the decimals that about eight ticks need.
fn tick(v: f64, span: f64) -> String {
    let d = (-(span.abs() / 8.0).log10()).ceil().clamp(0.0, 6.0);
    fixed(v, if d.is_finite() { d as usize } else { 0 })
}

/// A number rounded to two decimals with a typographic minus (captions): `−180`, `0.5`.
pub fn signed(v: f64) -> String {
    fixed((v * 100.0).round() / 100.0, 2)
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Writes `panels` side by side into a PNG at `path` (`size` pixels per panel side).
pub fn write_paths_png(
    path: &Path,
    fig: &PathFigure,
    panels: &[PathPanel],
    size: u32,
) -> Result<(), String> {
    write_paths_grid(path, fig, panels, panels.len().max(1), size)
}

/// Writes `panels` into a PNG at `path`, `cols` panels per row (`size` pixels per panel),
/// under the figure's title and legend.
pub fn write_paths_grid(
    path: &Path,
    fig: &PathFigure,
    panels: &[PathPanel],
    cols: usize,
    size: u32,
) -> Result<(), String> {
    let (w, h) = paths_grid_size(panels.len(), cols, size)?;
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    draw_paths_grid(&root, fig, panels, cols)?;
    root.present().map_err(err)
}

/// Pixel size `(width, height)` of a path grid of `n` panels, `cols` per row.
fn paths_grid_size(n: usize, cols: usize, size: u32) -> Result<(u32, u32), String> {
    if n == 0 || cols == 0 {
        return Err("no panels to plot".into());
    }
    let rows = n.div_ceil(cols);
    let cols = cols.min(n);
    Ok((
        size * cols as u32,
        TITLE_PX + LEGEND_PX + size * rows as u32,
    ))
}

/// Draws a path grid on `root` (any plotters backend).
fn draw_paths_grid<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &PathFigure,
    panels: &[PathPanel],
    cols: usize,
) -> Result<(), String> {
    ensure_font()?;
    for p in panels {
        if p.arm_dim == 0 || p.arm_dim > 3 || p.m == 0 || p.m % p.arm_dim != 0 {
            return Err(format!(
                "task dimension {} is not a stack of {}-D arms",
                p.m, p.arm_dim
            ));
        }
    }
    let cols = cols.min(panels.len()).max(1);
    let rows = panels.len().div_ceil(cols);
    root.fill(&WHITE).map_err(err)?;
    let (head, grid) = root.split_vertically(TITLE_PX + LEGEND_PX);
    let (title, legend) = head.split_vertically(TITLE_PX);
    let (w, _) = head.dim_in_pixel();
    title
        .draw(&Text::new(
            fig.title.clone(),
            (w as i32 / 2, TITLE_PX as i32 / 2),
            (FAMILY, 20)
                .into_font()
                .color(&BLACK)
                .pos(text_anchor::Pos::new(
                    text_anchor::HPos::Center,
                    text_anchor::VPos::Center,
                )),
        ))
        .map_err(err)?;
    let arms = panels.iter().map(|p| p.m / p.arm_dim).max().unwrap_or(1);
    let name = |s: &str, d: &str| {
        if s.is_empty() {
            d.to_string()
        } else {
            s.to_string()
        }
    };
    let has_nominal = panels
        .iter()
        .any(|p| p.paths.iter().any(|(n, _)| !n.is_empty()));
    let mut items = Vec::new();
    if has_nominal {
        items.push((NOMINAL, 5, name(&fig.nominal_name, "nominal")));
    }
    for arm in 0..arms {
        let arm_name = fig
            .arm_names
            .get(arm)
            .cloned()
            .unwrap_or_else(|| format!("arm {}", arm + 1));
        items.push((
            arm_colour(arm),
            2,
            format!("{}, {arm_name}", name(&fig.executed_name, "executed")),
        ));
    }
    draw_legend_strip(&legend, &items)?;
    let areas = grid.split_evenly((rows, cols));
    for (area, p) in areas.iter().zip(panels) {
        draw_panel(area, fig, p)?;
    }
    Ok(())
}

/// Draws legend entries `(colour, stroke, name)` in a row, centred in `area`.
fn draw_legend_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    items: &[(RGBColor, u32, String)],
) -> Result<(), String> {
    let font = (FAMILY, 14).into_font().color(&BLACK);
    let (w, h) = area.dim_in_pixel();
    let widths: Vec<i32> = items
        .iter()
        .map(|(_, _, s)| area.estimate_text_size(s, &font).map(|(tw, _)| tw as i32))
        .collect::<Result<_, _>>()
        .map_err(err)?;
    const SAMPLE: i32 = 28;
    const GAP: i32 = 22;
    let total: i32 = widths.iter().map(|tw| SAMPLE + 6 + tw).sum::<i32>()
        + GAP * (items.len() as i32 - 1).max(0);
    let mut x = ((w as i32 - total) / 2).max(4);
    let y = h as i32 / 2;
    for ((colour, stroke, s), tw) in items.iter().zip(widths) {
        area.draw(&PathElement::new(
            vec![(x, y), (x + SAMPLE, y)],
            colour.stroke_width(*stroke),
        ))
        .map_err(err)?;
        area.draw(&Text::new(
            s.clone(),
            (x + SAMPLE + 6, y),
            font.clone().pos(text_anchor::Pos::new(
                text_anchor::HPos::Left,
                text_anchor::VPos::Center,
            )),
        ))
        .map_err(err)?;
        x += SAMPLE + 6 + tw + GAP;
    }
    Ok(())
}

/// Draws one panel: caption, ticked equal-scale axes named after the view, the paths.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &PathFigure,
    p: &PathPanel,
) -> Result<(), String> {
    let (x0, x1, y0, y1) = p.bounds().ok_or("panel has no finite points")?;
    let area = if p.label.is_empty() {
        area.clone()
    } else {
        area.titled(&p.label, (FAMILY, 16)).map_err(err)?
    };
    // Equal scales: the spans in data units are proportional to the plot's pixel sides.
    let (aw, ah) = area.dim_in_pixel();
    let pw = (aw as f64 - 2.0 * MARGIN as f64 - Y_LABEL_PX as f64).max(10.0);
    let ph = (ah as f64 - 2.0 * MARGIN as f64 - X_LABEL_PX as f64).max(10.0);
    let scale = ((x1 - x0) / pw).max((y1 - y0) / ph).max(1e-12) * 1.1;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hx, hy) = (scale * pw / 2.0, scale * ph / 2.0);
    let mut chart = ChartBuilder::on(&area)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_PX)
        .y_label_area_size(Y_LABEL_PX)
        .build_cartesian_2d((cx - hx)..(cx + hx), (cy - hy)..(cy + hy))
        .map_err(err)?;
    let unit = |a: &[f64; 3]| {
        let n = axis_name(a, p.arm_dim);
        if fig.units.is_empty() {
            n
        } else {
            format!("{n} ({})", fig.units)
        }
    };
    let (sx, sy) = (2.0 * hx, 2.0 * hy);
    let fx = move |v: &f64| tick(*v, sx);
    let fy = move |v: &f64| tick(*v, sy);
    chart
        .configure_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .x_desc(unit(&p.view[0]))
        .y_desc(unit(&p.view[1]))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .light_line_style(RGBColor(247, 247, 247))
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()
        .map_err(err)?;
    let arms = p.m / p.arm_dim;
    for (nom, _) in &p.paths {
        for arm in 0..arms {
            chart
                .draw_series(LineSeries::new(
                    p.project(nom, arm),
                    NOMINAL.stroke_width(5),
                ))
                .map_err(err)?;
        }
    }
    for (_, exe) in &p.paths {
        for arm in 0..arms {
            chart
                .draw_series(LineSeries::new(
                    p.project(exe, arm),
                    arm_colour(arm).stroke_width(2),
                ))
                .map_err(err)?;
        }
    }
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

/// The words of a curve figure.
#[derive(Debug, Clone, Default)]
pub struct CurveFigure {
    /// Title above the chart.
    pub title: String,
    /// Horizontal axis name with units.
    pub x_desc: String,
    /// Vertical axis name with units.
    pub y_desc: String,
    /// Legend name of each curve (missing → no legend entry).
    pub names: Vec<String>,
    /// Unordered curves (joints): distinct colours, no grid lines at the samples; otherwise
    /// an ordered ramp (dark blue → orange) with faint lines at the first curve's `x`.
    pub categorical: bool,
    /// Ordered curves: how many are on the ramp; the rest (a reference) are drawn in
    /// black. `None`: all of them.
    pub ramp: Option<usize>,
}

/// Distinct colours of unordered curves (the ten of matplotlib's `tab10`).
const CATEGORICAL: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Writes polylines `y(x)` (colour `curve_colour(i, n)` for curve `i`) into one chart of
/// `width × height` pixels with the figure's title, axis names and legend, light grid lines
/// at the `x` values of the first curve, the `y` range including 0.
pub fn write_curves_png(
    path: &Path,
    fig: &CurveFigure,
    curves: &[Vec<(f64, f64)>],
    width: u32,
    height: u32,
) -> Result<(), String> {
    let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
    draw_curves(&root, fig, curves)?;
    root.present().map_err(err)
}

/// Draws a curve chart on `root` (any plotters backend).
fn draw_curves<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &CurveFigure,
    curves: &[Vec<(f64, f64)>],
) -> Result<(), String> {
    ensure_font()?;
    let (x0, x1, bottom, top) = curve_extent(curves)?;
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(root)
        .caption(&fig.title, (FAMILY, 20))
        .margin(12)
        .x_label_area_size(X_LABEL_PX)
        .y_label_area_size(Y_LABEL_PX + 8)
        .build_cartesian_2d(x0..x1, bottom..top)
        .map_err(err)?;
    let (sx, sy) = (x1 - x0, top - bottom);
    let fx = move |v: &f64| tick(*v, sx);
    let fy = move |v: &f64| tick(*v, sy);
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .x_desc(fig.x_desc.as_str())
        .y_desc(fig.y_desc.as_str())
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .bold_line_style(RGBColor(230, 230, 230))
        .light_line_style(RGBColor(245, 245, 245))
        .draw()
        .map_err(err)?;
    if let Some(first) = curves.first().filter(|_| !fig.categorical) {
        for &(x, _) in first {
            chart
                .draw_series(LineSeries::new(
                    [(x, bottom), (x, top)],
                    RGBColor(232, 232, 232),
                ))
                .map_err(err)?;
        }
    }
    for (i, c) in curves.iter().enumerate() {
        let colour = figure_colour(fig, i, curves.len());
        let series = chart
            .draw_series(LineSeries::new(
                c.iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite()),
                colour.stroke_width(2),
            ))
            .map_err(err)?;
        if let Some(name) = fig.names.get(i) {
            series.label(name.as_str()).legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 22, y)], colour.stroke_width(2))
            });
        }
    }
    if !fig.names.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FAMILY, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

/// The chart's ranges `(x0, x1, bottom, top)`: the finite points' `x` extent and their `y`
/// extent with 0, padded; refused when `x` has no extent.
fn curve_extent(curves: &[Vec<(f64, f64)>]) -> Result<(f64, f64, f64, f64), String> {
    let pts = curves
        .iter()
        .flatten()
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, 0.0f64, 0.0f64);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 >= x1 {
        return Err("curves have no finite extent".into());
    }
    let pad = 0.08 * (y1 - y0).max(1e-9);
    let top = if y1 > 0.0 { y1 + pad } else { pad };
    let bottom = if y0 < 0.0 { y0 - pad } else { 0.0 };
    Ok((x0, x1, bottom, top))
}

/// Colour of curve `i` of `n`: categorical, along the ramp, or black past the ramp.
fn figure_colour(fig: &CurveFigure, i: usize, n: usize) -> RGBColor {
    let ramp = fig.ramp.unwrap_or(n);
    if fig.categorical {
        CATEGORICAL[i % CATEGORICAL.len()]
    } else if i < ramp {
        curve_colour(i, ramp)
    } else {
        BLACK
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dark pixels (all channels < 128) of an RGB buffer inside rows `r0..r1`.
    fn ink(buf: &[u8], w: u32, r0: u32, r1: u32) -> usize {
        (r0..r1)
            .flat_map(|r| (0..w).map(move |c| ((r * w + c) * 3) as usize))
            .filter(|&i| buf[i] < 128 && buf[i + 1] < 128 && buf[i + 2] < 128)
            .count()
    }

    fn panel(label: &str) -> PathPanel {
        let nom: Vec<f64> = (0..50)
            .flat_map(|k| {
                let t = k as f64 / 49.0;
                [t, t * t, -t, t]
            })
            .collect();
        let exe: Vec<f64> = nom.iter().map(|v| v + 0.01).collect();
        PathPanel::single(4, 2, XY_VIEW, nom, exe, label)
    }

    fn render(fig: &PathFigure, label: &str) -> (Vec<u8>, u32, u32) {
        let (w, h) = paths_grid_size(1, 1, 320).unwrap();
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            draw_paths_grid(&root, fig, &[panel(label)], 1).unwrap();
            root.present().unwrap();
        }
        (buf, w, h)
    }

    #[test]
    fn a_title_and_a_caption_put_ink_where_they_belong() {
        // Rendered text is ink in the title strip; without words the strip stays white.
        let words = PathFigure {
            title: "Executed paths".into(),
            units: "m".into(),
            ..Default::default()
        };
        let (with, w, _) = render(&words, "θ = 90°, λ = 1, σ = +1");
        let (without, _, _) = render(&PathFigure::default(), "");
        assert!(ink(&with, w, 0, TITLE_PX) > 100, "title strip has no text");
        assert_eq!(ink(&without, w, 0, TITLE_PX), 0);
        // The caption is in the panel's first ~20 rows below the legend.
        let top = TITLE_PX + LEGEND_PX;
        assert!(ink(&with, w, top, top + 20) > 50, "panel caption missing");
        assert_eq!(ink(&without, w, top, top + 6), 0);
        // The legend strip names the series in both.
        assert!(ink(&without, w, TITLE_PX, top) > 100, "legend missing");
    }

    #[test]
    fn ticks_use_the_decimals_of_their_span_and_a_real_minus() {
        assert_eq!(tick(-2.0, 10.0), "−2");
        assert_eq!(tick(-2.5, 4.0), "−2.5");
        assert_eq!(tick(0.15, 0.38), "0.15");
        assert_eq!(tick(-0.0001, 1.0), "0.0");
        assert_eq!(tick(-150.0, 360.0), "−150");
        assert_eq!(signed(-180.0), "−180");
        assert_eq!(signed(0.5), "0.5");
    }

    #[test]
    fn axis_names_follow_the_view() {
        assert_eq!(axis_name(&[1.0, 0.0, 0.0], 2), "x");
        assert_eq!(axis_name(&[0.0, -1.0, 0.0], 3), "−y");
        assert_eq!(axis_name(&[0.5, 0.0, 0.866], 3), "0.5x + 0.87z");
        assert_eq!(axis_name(&[0.0, 0.0, 1.0], 2), "0");
    }

    #[test]
    fn condition_captions_read_like_the_paper() {
        let c = Condition {
            theta: std::f64::consts::FRAC_PI_2,
            scale: 1.2,
            reflection: -1,
        };
        assert_eq!(condition_label(&c), "θ = 90°, λ = 1.2, σ = −1");
    }
}
