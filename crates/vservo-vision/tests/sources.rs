//! Image sources: a directory of recorded images is read in file-name order, and bad files say why.

use image::GrayImage;
use vservo_vision::source::{DirectorySource, SourceError, read_gray_image};

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vservo-sources-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

#[test]
fn a_directory_is_read_in_name_order_and_wraps_around() {
    let dir = scratch("order");
    for (name, gray) in [("frame-002.png", 20_u8), ("frame-001.pgm", 10), ("frame-003.pgm", 30)] {
        GrayImage::from_pixel(8, 6, image::Luma([gray])).save(dir.join(name)).expect("write");
    }
    std::fs::write(dir.join("notes.txt"), "not an image").expect("write");
    let mut source = DirectorySource::open(&dir).expect("three images");
    assert_eq!(source.len(), 3);
    let grays: Vec<u8> =
        (0..4).map(|_| source.next_image().1.expect("readable").get_pixel(0, 0)[0]).collect();
    assert_eq!(grays, [10, 20, 30, 10]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn empty_directories_colour_images_and_junk_are_refused_with_the_path() {
    let dir = scratch("bad");
    assert!(matches!(DirectorySource::open(&dir), Err(SourceError::Empty(_))));
    assert!(matches!(DirectorySource::open(&dir.join("missing")), Err(SourceError::Directory { .. })));
    let colour = dir.join("colour.png");
    image::RgbImage::new(4, 4).save(&colour).expect("write");
    let error = read_gray_image(&colour).expect_err("colour is refused");
    assert!(
        error.to_string().contains("colour.png") && error.to_string().contains("not 8-bit grayscale"),
        "{error}"
    );
    let junk = dir.join("junk.pgm");
    std::fs::write(&junk, "P5 garbage").expect("write");
    assert!(read_gray_image(&junk).expect_err("junk").to_string().contains("junk.pgm"));
    let _ = std::fs::remove_dir_all(dir);
}
