//! Figure setup shared by every ddpkit figure: text through plotters' `ab_glyph` renderer with an
//! embedded font (DejaVu Sans, reduced to Latin-1 and Greek; `src/font/LICENSE-DejaVu.txt`), so no
//! figure needs a system font; a chart with a title, axis labels with units, a tick mesh and a
//! legend; PNGs drawn to a temporary file and renamed, so a figure is whole or absent.
//!
//! ```
//! use ddpkit_plot::{chart, legend, line_key, render_rgb, Axes};
//! use ddpkit_plot::plotters::prelude::*;
//!
//! let axes = Axes::new("Speed", "time (s)", "speed (m/s)", 0.0..10.0, 0.0..1.5);
//! let pixels = render_rgb((480, 320), |root| {
//!     let mut c = chart(root, &axes)?;
//!     let style = ShapeStyle::from(&BLUE).stroke_width(2);
//!     c.draw_series(LineSeries::new((0..=10).map(|t| (t as f64, 0.1 * t as f64)), style))?
//!         .label("commanded")
//!         .legend(line_key(style));
//!     legend(&mut c, SeriesLabelPosition::UpperLeft)
//! })?;
//! assert_eq!(pixels.len(), 480 * 320 * 3);
//! # Ok::<(), ddpkit_plot::PlotError>(())
//! ```

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub use plotters;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// DejaVu Sans, reduced to Basic Latin, Latin-1, Greek and a few symbols (about 24 kB).
static FONT: &[u8] = include_bytes!("font/DejaVuSans-subset.ttf");

/// The font family every figure uses (registered by [`fonts`]).
pub const FAMILY: &str = "sans-serif";

/// What stops a drawing: plotters' message or the file system's error.
pub type Failure = Box<dyn std::error::Error + Send + Sync>;

/// A chart in metres, seconds or any other `f64` units.
pub type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Why a figure was not written.
#[derive(Debug)]
pub enum PlotError {
    /// The file system refused (`path` names the file or folder).
    Io {
        /// The figure or its folder.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Drawing or encoding failed, or the figure's size is out of range.
    Draw {
        /// The figure (empty for in-memory renders).
        path: PathBuf,
        /// The reason.
        reason: String,
    },
}

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Self::Draw { path, reason } if path.as_os_str().is_empty() => write!(f, "figure: {reason}"),
            Self::Draw { path, reason } => write!(f, "{}: {reason}", path.display()),
        }
    }
}

impl std::error::Error for PlotError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            Self::Draw { .. } => None,
        }
    }
}

/// Registers the embedded font under `sans-serif`, `serif` and `monospace` (once per process;
/// later calls are free). [`write_png`] and [`render_rgb`] call it.
pub fn fonts() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        ["sans-serif", "serif", "monospace"]
            .iter()
            .all(|name| plotters::style::register_font(name, FontStyle::Normal, FONT).is_ok())
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw {
            path: PathBuf::new(),
            reason: "the embedded font does not load".into(),
        })
    }
}

/// Title, axis labels (with units) and ranges of one chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Axes {
    /// Chart title, above the plot.
    pub title: String,
    /// x axis label, e.g. `"x (m)"`.
    pub x_label: String,
    /// y axis label.
    pub y_label: String,
    /// x range.
    pub x: Range<f64>,
    /// y range.
    pub y: Range<f64>,
    /// Draw the title, tick labels and axis labels (off only to compare renders in tests;
    /// figures then leave out their legend too).
    pub text: bool,
}

impl Axes {
    /// Axes with tick labels.
    pub fn new(title: &str, x_label: &str, y_label: &str, x: Range<f64>, y: Range<f64>) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x,
            y,
            text: true,
        }
    }
}

/// Pixels kept around a chart's plotting area: `(left, bottom, top, outer margin)` for the y tick
/// labels and label, the x tick labels and label, the title, and the edge.
pub const FRAME: (u32, u32, u32, u32) = (64, 48, 36, 12);

/// The figure size at which `x` by `y` metres (a top view) draws at `px_per_m` with equal axes,
/// frame included.
pub fn equal_aspect_size(x: &Range<f64>, y: &Range<f64>, px_per_m: f64) -> (u32, u32) {
    let (left, bottom, top, m) = FRAME;
    (
        ((x.end - x.start) * px_per_m).ceil().max(16.0) as u32 + left + 2 * m,
        ((y.end - y.start) * px_per_m).ceil().max(16.0) as u32 + bottom + top + 2 * m,
    )
}

/// A chart on `area` with the title, the axis labels and a light tick mesh (about ten ticks
/// per axis, each labelled).
pub fn chart<'a, DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, axes: &Axes) -> Result<Chart<'a, DB>, Failure>
where
    DB::ErrorType: 'static,
{
    let (left, bottom, top, m) = FRAME;
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(m)
        .margin_top(0)
        .x_label_area_size(bottom)
        .y_label_area_size(left);
    if axes.text && !axes.title.is_empty() {
        builder.caption(&axes.title, (FAMILY, 18));
    } else {
        builder.margin_top(top);
    }
    let mut c = builder.build_cartesian_2d(axes.x.clone(), axes.y.clone())?;
    let mut mesh = c.configure_mesh();
    mesh.light_line_style(RGBColor(236, 236, 236))
        .bold_line_style(RGBColor(210, 210, 210))
        .axis_style(BLACK.stroke_width(1))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .x_labels(10)
        .y_labels(10);
    if axes.text {
        mesh.x_desc(&axes.x_label).y_desc(&axes.y_label);
    } else {
        mesh.x_label_formatter(&|_| String::new())
            .y_label_formatter(&|_| String::new());
    }
    mesh.draw()?;
    Ok(c)
}

/// Draws the legend of the series labelled so far, on a white box with a grey border.
pub fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    position: SeriesLabelPosition,
) -> Result<(), Failure>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(150, 150, 150))
        .label_font((FAMILY, 13))
        .margin(8)
        .draw()?;
    Ok(())
}

/// A pixel position on a figure (plotters' backend coordinate).
pub type BackendCoord = (i32, i32);

/// A legend key for a line of `style` (dashed as 6 px on, 4 px off when `dashed`).
pub fn line_key(style: ShapeStyle) -> impl Fn(BackendCoord) -> PathElement<BackendCoord> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style)
}

/// A legend key for a dashed line of `style`.
pub fn dashed_key(
    style: ShapeStyle,
) -> impl Fn(BackendCoord) -> DashedPathElement<std::vec::IntoIter<BackendCoord>, i32> {
    move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 20, y)], 6, 4, style)
}

/// A legend key for a disc marker of `style` and radius `r` pixels.
pub fn disc_key(style: ShapeStyle, r: i32) -> impl Fn(BackendCoord) -> Circle<BackendCoord, i32> {
    move |(x, y)| Circle::new((x + 10, y), r, style)
}

/// A legend key for a cross marker of `style`.
pub fn cross_key(style: ShapeStyle) -> impl Fn(BackendCoord) -> Cross<BackendCoord, i32> {
    move |(x, y)| Cross::new((x + 10, y), 5, style)
}

/// A legend key for a filled square of `style` (areas: obstacles, histogram bars).
pub fn box_key(style: ShapeStyle) -> impl Fn(BackendCoord) -> Rectangle<BackendCoord> {
    move |(x, y)| Rectangle::new([(x + 4, y - 5), (x + 16, y + 5)], style)
}

fn check_size(path: &Path, (w, h): (u32, u32)) -> Result<(), PlotError> {
    if !(16..=20_000).contains(&w) || !(16..=20_000).contains(&h) {
        return Err(PlotError::Draw {
            path: path.to_path_buf(),
            reason: format!("figure of {w} x {h} pixels is out of range (16 to 20000 per side)"),
        });
    }
    Ok(())
}

/// Draws a `size` PNG to `path` through `draw`: the folder is created, the fonts registered, the
/// image drawn to a temporary file next to `path` and renamed, so the figure is whole or absent.
pub fn write_png<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), PlotError>
where
    F: FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), Failure>,
{
    check_size(path, size)?;
    fonts()?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let drawn = ddpkit_util::fs::write_atomic_at(path, |tmp: &Path| -> Result<(), Failure> {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
        Ok(())
    });
    drawn.map_err(|e| match e.downcast::<std::io::Error>() {
        Ok(source) => PlotError::Io {
            path: path.to_path_buf(),
            source: *source,
        },
        Err(e) => PlotError::Draw {
            path: path.to_path_buf(),
            reason: e.to_string(),
        },
    })
}

/// Draws a `size` figure in memory and returns its RGB pixels, row by row (tests, previews).
pub fn render_rgb<F>(size: (u32, u32), draw: F) -> Result<Vec<u8>, PlotError>
where
    F: FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), Failure>,
{
    check_size(Path::new(""), size)?;
    fonts()?;
    let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
    let drawn = (|| -> Result<(), Failure> {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
        Ok(())
    })();
    drawn.map_err(|e| PlotError::Draw {
        path: PathBuf::new(),
        reason: e.to_string(),
    })?;
    Ok(buf)
}

/// Pixels darker than mid-grey in the rectangle `[x0, x1) x [y0, y1)` of an RGB image `width`
/// pixels wide (text and lines on white): how tests see that text was drawn.
pub fn dark_pixels(rgb: &[u8], width: u32, x: Range<u32>, y: Range<u32>) -> usize {
    let w = width as usize;
    let mut n = 0;
    for row in y {
        for col in x.clone() {
            let i = 3 * (row as usize * w + col as usize);
            if let Some(p) = rgb.get(i..i + 3) {
                if (p[0] as u32 + p[1] as u32 + p[2] as u32) < 3 * 128 {
                    n += 1;
                }
            }
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(text: bool) -> Vec<u8> {
        let mut axes = Axes::new("A test figure", "x (m)", "y (m)", 0.0..10.0, -2.0..2.0);
        axes.text = text;
        render_rgb((600, 400), |root| {
            let mut c = chart(root, &axes)?;
            let style = ShapeStyle::from(&RGBColor(200, 200, 255)).stroke_width(2);
            c.draw_series(LineSeries::new((0..=20).map(|k| (0.5 * k as f64, 0.0)), style))?
                .label("a long legend entry")
                .legend(line_key(style));
            if text {
                legend(&mut c, SeriesLabelPosition::UpperRight)?;
            }
            Ok(())
        })
        .unwrap()
    }

    #[test]
    fn legend_ticks_and_title_draw_text() {
        let (with, without) = (figure(true), figure(false));
        let (left, bottom, _, m) = FRAME;
        // x tick labels: the band under the plotting area.
        let band = |img: &[u8]| dark_pixels(img, 600, left + m..600 - m, 400 - bottom - m + 4..400 - m - 18);
        // y tick labels: the band left of the plotting area.
        let yband = |img: &[u8]| dark_pixels(img, 600, m + 20..left + m - 4, 40..400 - bottom - m);
        // Legend: upper right, inside the plot (the light line itself is not dark).
        let legend = |img: &[u8]| dark_pixels(img, 600, 380..590, 40..90);
        // Title: the top band.
        let title = |img: &[u8]| dark_pixels(img, 600, 0..600, 0..30);
        for (name, f) in [
            ("x ticks", &band as &dyn Fn(&[u8]) -> usize),
            ("y ticks", &yband),
            ("legend", &legend),
            ("title", &title),
        ] {
            let (a, b) = (f(&with), f(&without));
            assert!(a > b + 40, "{name}: {a} dark pixels with text, {b} without");
        }
    }

    #[test]
    fn pngs_are_whole_and_sizes_checked() {
        let dir = std::env::temp_dir().join(format!("ddpkit-plot-test-{}", std::process::id()));
        let path = dir.join("sub").join("f.png");
        let axes = Axes::new("t", "x (m)", "y (m)", 0.0..1.0, 0.0..1.0);
        write_png(&path, (200, 150), |root| chart(root, &axes).map(|_| ())).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        // A failing drawing leaves nothing behind.
        let bad = dir.join("bad.png");
        let e = write_png(&bad, (200, 150), |_| Err("no".into())).unwrap_err();
        assert!(e.to_string().contains("bad.png") && e.to_string().contains("no"), "{e}");
        assert!(!bad.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "no temporary files left");
        let e = write_png(&bad, (0, 150), |_| Ok(())).unwrap_err();
        assert!(e.to_string().contains("0 x 150"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
