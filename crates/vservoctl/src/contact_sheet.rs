//! `vservoctl plot --frames N`: a contact sheet of a recording's camera images (`vservoctl record
//! --image-every`), N of them spread evenly over it, each with its marks drawn (`crate::annotate`: found, wanted,
//! the error) and a caption (frame, time, the largest mark error), as one SVG with the images embedded
//! (`frames.svg`), and what was drawn where as JSON (`frames.json`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result, bail};
use base64::Engine as _;
use foxglove::messages::RawImage;
use nalgebra::Point2;
use prost::Message as _;
use serde_json::{Value, json};
use vservo_config::Config;
use vservo_protocol::MARKS;

use crate::annotate;

/// The width of each picture on the sheet (px); a larger image is scaled down to it.
const CELL_WIDTH_PX: u32 = 320;
/// Pictures per row.
const COLUMNS: usize = 4;
/// Room for a caption under each picture, and for the legend (px).
const CAPTION_PX: u32 = 22;

/// A recorded frame's features, by its capture stamp.
struct Features {
    frame: u64,
    features_px: [f64; 2 * MARKS],
    valid_mask: u32,
}

/// One picture of the sheet.
struct Cell {
    png: Vec<u8>,
    width: u32,
    height: u32,
    caption: String,
    record: Value,
}

/// Writes `frames.svg` and `frames.json` into `out` with `count` frames of the recording in `bytes`; how many.
pub fn write(bytes: &[u8], config: &Config, count: usize, out: &Path) -> Result<usize> {
    let (images, features, desired) = read(bytes, config)?;
    let paired: Vec<(&RawImage, &Features, u64)> =
        images.iter().filter_map(|(stamp, image)| features.get(stamp).map(|f| (image, f, *stamp))).collect();
    if paired.is_empty() {
        bail!(
            "the recording holds no camera image with its features: record with --image-every N (N ≥ 1) while the \
             camera runs"
        );
    }
    let first_stamp = paired[0].2;
    let chosen = spread(paired.len(), count);
    let cells: Vec<Cell> = chosen
        .iter()
        .map(|&i| {
            let (image, features, stamp) = paired[i];
            cell(image, features, &desired, config, vservo_time::seconds_between(stamp, first_stamp))
        })
        .collect::<Result<_>>()?;
    crate::output::write_in(out, "frames.svg", sheet(&cells).as_bytes())?;
    let records: Vec<&Value> = cells.iter().map(|c| &c.record).collect();
    crate::output::write_in(out, "frames.json", format!("{}\n", json!({ "frames": records })).as_bytes())?;
    Ok(cells.len())
}

/// `count` indices of `len`, evenly spread from the first to the last (all of them when there are fewer).
fn spread(len: usize, count: usize) -> Vec<usize> {
    if count >= len {
        return (0..len).collect();
    }
    if count <= 1 {
        return vec![0];
    }
    (0..count).map(|k| (k * (len - 1) + (count - 1) / 2) / (count - 1)).collect()
}

type Read = (Vec<(u64, RawImage)>, BTreeMap<u64, Features>, [f64; 2 * MARKS]);

/// The recording's images (by capture stamp), its features (by capture stamp) and the last ξ_d its gains said.
fn read(bytes: &[u8], config: &Config) -> Result<Read> {
    let mut images = Vec::new();
    let mut features = BTreeMap::new();
    let mut desired: [f64; 2 * MARKS] = std::array::from_fn(|i| config.cell.desired.features[i]);
    for message in mcap::MessageStream::new(bytes)? {
        let message = message?;
        if message.channel.topic == vservo_view::drawing::IMAGE_TOPIC {
            let image =
                RawImage::decode(&message.data[..]).context("a camera image that is not a RawImage")?;
            let stamp = image
                .timestamp
                .map_or(0, |t| vservo_time::Nanos::from_parts(u64::from(t.sec()), t.nsec()).get());
            images.push((stamp, image));
            continue;
        }
        if message.channel.message_encoding != "json" {
            continue;
        }
        let topic = message.channel.topic.rsplit('/').next().unwrap_or_default();
        let data: Value = serde_json::from_slice(&message.data).context("a message that is not JSON")?;
        let numbers = |value: &Value| -> [f64; 2 * MARKS] {
            std::array::from_fn(|i| value[i].as_f64().unwrap_or(f64::NAN))
        };
        match topic {
            "features" => {
                let (Some(frame), Some(stamp)) = (data["frame"].as_u64(), data["capture_stamp_ns"].as_u64())
                else {
                    continue;
                };
                let valid_mask = data["valid_mask"].as_u64().unwrap_or(0) as u32;
                features.insert(
                    stamp,
                    Features { frame, features_px: numbers(&data["features_px"]), valid_mask },
                );
            }
            "gains" if data["desired_features_px"].is_array() => {
                desired = numbers(&data["desired_features_px"])
            }
            _ => {}
        }
    }
    Ok((images, features, desired))
}

/// One frame drawn: scaled to the sheet's width, its marks on it.
fn cell(
    image: &RawImage,
    features: &Features,
    desired: &[f64; 2 * MARKS],
    config: &Config,
    t_s: f64,
) -> Result<Cell> {
    if image.encoding != "mono8" || image.step < image.width {
        bail!(
            "a recorded image is {} with rows of {} bytes, not mono8 of {}",
            image.encoding,
            image.step,
            image.width
        );
    }
    let gray = annotate::gray_to_rgb(image.width, image.height, image.step, &image.data);
    let scale = (f64::from(CELL_WIDTH_PX) / f64::from(image.width)).min(1.0);
    let (width, height) =
        ((f64::from(image.width) * scale).round() as u32, (f64::from(image.height) * scale).round() as u32);
    let mut picture = image::imageops::resize(&gray, width, height, image::imageops::FilterType::Triangle);
    let shown = |x: f64, y: f64| {
        let point = Point2::new(x, y);
        let in_image =
            if config.cell.vision.undistort { config.cell.camera.observed_of_pinhole(&point) } else { point };
        Point2::new(in_image.x * scale, in_image.y * scale)
    };
    let drawn =
        annotate::draw_marks(&mut picture, &features.features_px, features.valid_mask, desired, shown);
    let largest = drawn.iter().filter_map(annotate::MarkDrawn::error_px).fold(f64::NAN, f64::max) / scale;
    let seen = drawn.iter().filter(|d| d.found.is_some()).count();
    let caption = if seen == MARKS {
        format!("frame {} · {t_s:.2} s · largest error {largest:.2} px", features.frame)
    } else {
        format!("frame {} · {t_s:.2} s · {seen} of {MARKS} marks seen", features.frame)
    };
    let mut png = std::io::Cursor::new(Vec::new());
    picture.write_to(&mut png, image::ImageFormat::Png).context("encoding a PNG")?;
    let found: Vec<Option<[f64; 2]>> = drawn.iter().map(|d| d.found.map(|p| [p.x, p.y])).collect();
    let record = json!({"frame": features.frame, "t_s": t_s, "scale": scale, "found_px_on_sheet": found, "caption": caption});
    Ok(Cell { png: png.into_inner(), width, height, caption, record })
}

/// The SVG: a legend, then the pictures row by row, each with its caption.
fn sheet(cells: &[Cell]) -> String {
    let cell_width = cells.iter().map(|c| c.width).max().unwrap_or(CELL_WIDTH_PX) + 8;
    let cell_height = cells.iter().map(|c| c.height).max().unwrap_or(240) + CAPTION_PX + 8;
    let rows = cells.len().div_ceil(COLUMNS);
    let columns = cells.len().min(COLUMNS);
    let (width, height) = (columns as u32 * cell_width, rows as u32 * cell_height + CAPTION_PX);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"4\" y=\"15\" font-family=\"sans-serif\" font-size=\"12\">\
         <tspan fill=\"rgb(0,160,0)\">+ mark found</tspan>  <tspan fill=\"rgb(230,0,0)\">○ where the servo wants it (ξ_d)</tspan>  \
         <tspan fill=\"rgb(170,150,0)\">— the error</tspan></text>\n"
    );
    for (k, cell) in cells.iter().enumerate() {
        let x = (k % COLUMNS) as u32 * cell_width + 4;
        let y = (k / COLUMNS) as u32 * cell_height + CAPTION_PX;
        let data = base64::engine::general_purpose::STANDARD.encode(&cell.png);
        let _ = writeln!(
            svg,
            "<image x=\"{x}\" y=\"{y}\" width=\"{}\" height=\"{}\" href=\"data:image/png;base64,{data}\"/>",
            cell.width, cell.height
        );
        let _ = writeln!(
            svg,
            "<text x=\"{x}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"12\">{}</text>",
            y + cell.height + 15,
            cell.caption
        );
    }
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::spread;

    #[test]
    fn frames_are_spread_from_the_first_to_the_last() {
        assert_eq!(spread(10, 4), [0, 3, 6, 9]);
        assert_eq!(spread(100, 2), [0, 99]);
        assert_eq!(spread(3, 8), [0, 1, 2]);
        assert_eq!(spread(5, 1), [0]);
    }
}
