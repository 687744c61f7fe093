//! `radiosity sunset`: one bake, then frames whose sun and sky change; the GIF's first frame is
//! a day's, its last a sunset's, and the file carries the sky visibility that lit them.

use super::radiosity_ok;

/// Mean red over mean blue of a frame (sRGB codes).
fn warmth(frame: &image::RgbaImage) -> f64 {
    let (mut r, mut b) = (0u64, 0u64);
    for p in frame.pixels() {
        r += u64::from(p[0]);
        b += u64::from(p[2]);
    }
    r as f64 / b.max(1) as f64
}

#[test]
fn one_bake_and_the_sun_goes_down() {
    use image::AnimationDecoder;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let stdout = radiosity_ok(&[
        "sunset",
        "--out",
        out,
        "--frames",
        "4",
        "--patches",
        "384",
        "--width",
        "64",
        "--height",
        "48",
    ])
    .stdout;
    let text = String::from_utf8(stdout).unwrap();
    assert!(text.contains("4 frames 64×48"), "{text}");
    let gif = std::fs::File::open(dir.path().join("sunset.gif")).unwrap();
    let frames: Vec<image::RgbaImage> =
        image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif))
            .unwrap()
            .into_frames()
            .map(|f| f.unwrap().into_buffer())
            .collect();
    assert_eq!(frames.len(), 4);
    assert_eq!(frames[0].dimensions(), (64, 48));
    // The sun at 34° against 0.5°: through 1.2 against 30 air masses its blue falls far more
    // than its red, and the sky follows; each frame has its own exposure, so the colour, not
    // the brightness, is what changes. A margin of 1.3× is far below what the model gives.
    let (first, last) = (warmth(&frames[0]), warmth(&frames[3]));
    assert!(last > 1.3 * first, "warmth {first} then {last}");
    let file = std::fs::read(dir.path().join("sunset.rad")).unwrap();
    let rad = radiosity_core::RadFile::parse(&file).unwrap();
    assert!(rad.sky.is_some_and(|s| !s.is_closed()));
}
