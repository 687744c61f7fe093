//! The charts of `radiosity report`: PNG charts with plotters (drawn into memory by its bitmap backend, encoded by `image`; text
//! through `ab_glyph` with the bundled DejaVu Sans, so no system font library is needed) and
//! matrix images with `image`.

use anyhow::{Context, anyhow};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// DejaVu Sans (Bitstream Vera licence with DejaVu changes in the public domain; see
/// `assets/fonts/LICENSE-DejaVu.txt`).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

fn register_font() -> anyhow::Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .map_err(|_| anyhow!("the bundled font cannot be read"));
    });
    result
}

fn pe<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e:?}")
}

/// Palette for series, distinguishable in print.
pub const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// A named set of points.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Join the points with a line (sorted by x) as well as marking them.
    pub line: bool,
}

/// A scatter/line chart on log-log (or lin-log) axes.
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub log_x: bool,
    pub series: Vec<Series>,
    /// A polyline drawn in black over the points (the Pareto front), with its legend name.
    pub front: Option<(String, Vec<(f64, f64)>)>,
}

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let v: Vec<f64> = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        let pad = ((hi - lo) * 0.05).max(1e-9);
        (lo - pad, hi + pad)
    }
}

/// Draws `chart` into `path` (960×640).
pub fn chart(path: &Path, chart: &Chart<'_>) -> anyhow::Result<()> {
    register_font()?;
    let (w, h) = (960, 640);
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let all = || chart.series.iter().flat_map(|s| s.points.iter().copied());
        let (x0, x1) = range(all().map(|p| p.0), chart.log_x);
        let (y0, y1) = range(all().map(|p| p.1), true);
        let mut c = ChartBuilder::on(&root);
        c.caption(chart.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(80);
        if chart.log_x {
            let mut cc = c
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(pe)?;
            cc.configure_mesh()
                .x_desc(chart.x_label)
                .y_desc(chart.y_label)
                .label_style((FAMILY, 14))
                .x_labels(8)
                .x_label_formatter(&|v| short(*v))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(pe)?;
            draw_series(&mut cc, chart)?;
        } else {
            let mut cc = c
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(pe)?;
            cc.configure_mesh()
                .x_desc(chart.x_label)
                .y_desc(chart.y_label)
                .label_style((FAMILY, 14))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(pe)?;
            draw_series(&mut cc, chart)?;
        }
        root.present().map_err(pe)?;
    }
    save(path, w, h, buf)
}

fn draw_series<'a, 'b: 'a, X, Y>(
    cc: &mut ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>,
    chart: &Chart<'_>,
) -> anyhow::Result<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for (k, s) in chart.series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let mut pts = s.points.clone();
        pts.retain(|p| p.0.is_finite() && p.1.is_finite() && p.1 > 0.0);
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if s.line {
            cc.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(pe)?;
        }
        cc.draw_series(pts.iter().map(|p| Circle::new(*p, 5, colour.filled())))
            .map_err(pe)?
            .label(s.name.clone())
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, colour.filled()));
    }
    if let Some((name, front)) = &chart.front {
        cc.draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2)))
            .map_err(pe)?
            .label(name.clone())
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        cc.draw_series(
            front
                .iter()
                .map(|p| Circle::new(*p, 8, BLACK.stroke_width(2))),
        )
        .map_err(pe)?;
    }
    cc.configure_series_labels()
        .label_font((FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(pe)?;
    Ok(())
}

/// Writes an RGB buffer as PNG, atomically (plotters draws into memory; the `image` crate the
/// rest of the program uses encodes, so plotters needs no encoder of its own).
fn save(path: &Path, w: u32, h: u32, buf: Vec<u8>) -> anyhow::Result<()> {
    let img = image::RgbImage::from_raw(w, h, buf).context("plot buffer size")?;
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    Ok(radiosity_bake::host::write_atomic(path, png.get_ref())?)
}

/// A tick label: `1e-3`-style for very small or large values, else at most 3 significant digits.
fn short(v: f64) -> String {
    if v != 0.0 && !(1e-2..1e5).contains(&v.abs()) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_owned()
    }
}

/// A bar chart with a log value axis: one bar per `(label, value)`, optionally grouped by
/// colour (`group` indexes [`COLOURS`]).
pub fn bars(
    path: &Path,
    title: &str,
    y_label: &str,
    bars: &[(String, f64, usize)],
    groups: &[&str],
) -> anyhow::Result<()> {
    register_font()?;
    let (w, h) = (960, 640);
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let (y0, y1) = range(bars.iter().map(|b| b.1), true);
        let n = bars.len().max(1);
        let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        let mut cc = ChartBuilder::on(&root)
            .caption(title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(90)
            .y_label_area_size(80)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), (y0..y1).log_scale())
            .map_err(pe)?;
        cc.configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .x_label_style((FAMILY, 13).into_font().transform(FontTransform::Rotate90))
            .y_desc(y_label)
            .label_style((FAMILY, 14))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(pe)?;
        for (i, (_, v, g)) in bars.iter().enumerate() {
            let colour = COLOURS[g % COLOURS.len()];
            cc.draw_series(std::iter::once(Rectangle::new(
                [(i as f64 - 0.35, y0), (i as f64 + 0.35, *v)],
                colour.filled(),
            )))
            .map_err(pe)?;
        }
        for (g, name) in groups.iter().enumerate() {
            let colour = COLOURS[g % COLOURS.len()];
            cc.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                .map_err(pe)?
                .label(*name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled())
                });
        }
        if !groups.is_empty() {
            cc.configure_series_labels()
                .label_font((FAMILY, 14))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(pe)?;
        }
        root.present().map_err(pe)?;
    }
    save(path, w, h, buf)
}

/// Histograms side by side (the paper's Fig. 1): counts of `log10(value)` of the non-zero
/// entries in bins of 0.1 decade, and of the values themselves on a linear axis (40 bins up
/// to the largest), one colour per named data set.
pub fn value_histograms(path: &Path, title: &str, sets: &[(&str, &[f32])]) -> anyhow::Result<()> {
    register_font()?;
    let (w, h) = (1200, 520);
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let (left, right) = root.split_horizontally(600);
        log_histogram(&left, title, sets)?;
        linear_histogram(&right, title, sets)?;
        root.present().map_err(pe)?;
    }
    save(path, w, h, buf)
}

/// One half of [`value_histograms`]'s image.
type Half<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Per set, the counts of `log10(value)` of its positive entries in bins of 0.1 decade:
/// `(bin start, count)` in increasing order.
fn log_bins(sets: &[(&str, &[f32])]) -> Vec<Vec<(f64, f64)>> {
    sets.iter()
        .map(|(_, v)| {
            let mut h = std::collections::BTreeMap::<i64, f64>::new();
            for x in v.iter().filter(|x| **x > 0.0) {
                *h.entry((f64::from(*x).log10() * 10.0).floor() as i64)
                    .or_default() += 1.0;
            }
            h.into_iter().map(|(b, c)| (b as f64 / 10.0, c)).collect()
        })
        .collect()
}

/// The log-scale histogram of the non-zero entries, with a legend of the sets.
fn log_histogram(area: &Half<'_>, title: &str, sets: &[(&str, &[f32])]) -> anyhow::Result<()> {
    let bins_log = log_bins(sets);
    let l = area
        .titled(
            &format!("{title}: log10(value), non-zero entries"),
            (FAMILY, 18),
        )
        .map_err(pe)?;
    let xs = bins_log.iter().flatten().map(|p| p.0);
    let (x0, x1) = (
        xs.clone().fold(f64::INFINITY, f64::min) - 0.2,
        xs.fold(f64::NEG_INFINITY, f64::max) + 0.3,
    );
    let (x0, x1) = if x0.is_finite() {
        (x0, x1)
    } else {
        (-1.0, 1.0)
    };
    let ymax = bins_log.iter().flatten().map(|p| p.1).fold(1.0, f64::max) * 1.5;
    let mut cc = ChartBuilder::on(&l)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, (0.5..ymax).log_scale())
        .map_err(pe)?;
    cc.configure_mesh()
        .x_desc("log10(value)")
        .y_desc("entries")
        .label_style((FAMILY, 13))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(pe)?;
    for (k, (bins, (name, _))) in bins_log.iter().zip(sets).enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        cc.draw_series(
            bins.iter().map(|(x, c)| {
                Rectangle::new([(*x, 0.5), (*x + 0.1, *c)], colour.mix(0.5).filled())
            }),
        )
        .map_err(pe)?
        .label(*name)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled()));
    }
    cc.configure_series_labels()
        .label_font((FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(pe)?;
    Ok(())
}

/// Per set, the counts of its entries in 40 equal bins from 0 to `vmax`.
fn linear_bins(sets: &[(&str, &[f32])], vmax: f32) -> Vec<Vec<f64>> {
    sets.iter()
        .map(|(_, v)| {
            let mut h = vec![0f64; 40];
            for x in v.iter() {
                let b = ((x / vmax) * 40.0) as usize;
                h[b.min(39)] += 1.0;
            }
            h
        })
        .collect()
}

/// The linear histogram of every entry: most fall in the first bin (the paper's point).
fn linear_histogram(area: &Half<'_>, title: &str, sets: &[(&str, &[f32])]) -> anyhow::Result<()> {
    let r = area
        .titled(&format!("{title}: value, linear bins"), (FAMILY, 18))
        .map_err(pe)?;
    let vmax = sets
        .iter()
        .flat_map(|(_, v)| v.iter())
        .fold(0f32, |a, b| a.max(*b))
        .max(1e-30);
    let bins_lin = linear_bins(sets, vmax);
    let ymax = bins_lin.iter().flatten().fold(1.0f64, |a, b| a.max(*b)) * 1.5;
    let w = f64::from(vmax) / 40.0;
    let mut cc = ChartBuilder::on(&r)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..f64::from(vmax), (0.5..ymax).log_scale())
        .map_err(pe)?;
    cc.configure_mesh()
        .x_desc("value")
        .y_desc("entries")
        .label_style((FAMILY, 13))
        .x_label_formatter(&|v| format!("{v:.1e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(pe)?;
    for (k, bins) in bins_lin.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        cc.draw_series(
            bins.iter()
                .enumerate()
                .filter(|(_, c)| **c > 0.0)
                .map(|(b, c)| {
                    Rectangle::new(
                        [(b as f64 * w, 0.5), ((b as f64 + 1.0) * w, *c)],
                        colour.mix(0.5).filled(),
                    )
                }),
        )
        .map_err(pe)?;
    }
    Ok(())
}

/// A colour ramp for `t` in [0, 1]: black → blue → orange → white (perceptually ordered).
fn ramp(t: f32) -> image::Rgb<u8> {
    let t = t.clamp(0.0, 1.0);
    let stops = [
        (0.0, [0.0, 0.0, 0.0]),
        (0.35, [0.15, 0.2, 0.7]),
        (0.7, [0.95, 0.5, 0.1]),
        (1.0, [1.0, 1.0, 0.9]),
    ];
    for w in stops.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if t <= b {
            let s = (t - a) / (b - a);
            return image::Rgb(std::array::from_fn(|k| {
                ((ca[k] + s * (cb[k] - ca[k])) * 255.0 + 0.5) as u8
            }));
        }
    }
    image::Rgb([255, 255, 230])
}

/// An image of an `n × n` grid of non-negative values (`value(r, c)`), `side` pixels square:
/// each pixel shows the largest value of the entries it covers (or the one entry it samples
/// when zoomed in), as `log10` over `decades` below `top`, through [`ramp`].
pub fn matrix_image(
    n: usize,
    side: u32,
    value: &dyn Fn(usize, usize) -> f32,
    top: f32,
    decades: f32,
) -> image::RgbImage {
    let mut img = image::RgbImage::new(side, side);
    let per = n as f64 / f64::from(side);
    let lt = top.max(1e-30).log10();
    for py in 0..side {
        for px in 0..side {
            let (r0, c0) = (
                (f64::from(py) * per) as usize,
                (f64::from(px) * per) as usize,
            );
            let (r1, c1) = (
                ((f64::from(py + 1) * per) as usize).max(r0 + 1).min(n),
                ((f64::from(px + 1) * per) as usize).max(c0 + 1).min(n),
            );
            let mut m = 0f32;
            for r in r0..r1 {
                for c in c0..c1 {
                    m = m.max(value(r, c));
                }
            }
            let t = if m > 0.0 {
                1.0 - (lt - m.log10()) / decades
            } else {
                0.0
            };
            img.put_pixel(px, py, ramp(t));
        }
    }
    img
}

/// Puts images side by side with a gap, on white.
pub fn side_by_side(images: &[&image::RgbImage], gap: u32) -> image::RgbImage {
    let w: u32 = images.iter().map(|i| i.width()).sum::<u32>()
        + gap * (images.len() as u32).saturating_sub(1);
    let h = images.iter().map(|i| i.height()).max().unwrap_or(0);
    let mut out = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    let mut x = 0i64;
    for i in images {
        image::imageops::replace(&mut out, *i, x, 0);
        x += i64::from(i.width() + gap);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both halves of the histogram image draw the set's bars: pixels of its colour (blue,
    /// half mixed into white) on the left (log bins) and on the right (linear bins).
    #[test]
    fn value_histograms_draw_both_halves() {
        let values: Vec<f32> = (1..=2000).map(|i| 1e-4 * (i as f32).powi(2)).collect();
        let dir = std::env::temp_dir().join(format!("radiosity-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("histograms.png");
        value_histograms(&path, "test", &[("squares", &values)]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(img.dimensions(), (1200, 520));
        let bluish = |x0: u32, x1: u32| {
            (x0..x1)
                .flat_map(|x| (0..520).map(move |y| (x, y)))
                .filter(|&(x, y)| {
                    let [r, g, b] = img.get_pixel(x, y).0;
                    i32::from(b) > i32::from(r) + 20 && i32::from(b) > i32::from(g)
                })
                .count()
        };
        let (left, right) = (bluish(0, 600), bluish(600, 1200));
        assert!(left > 1000, "log bins: {left} pixels of the set's colour");
        assert!(
            right > 1000,
            "linear bins: {right} pixels of the set's colour"
        );
    }
}
