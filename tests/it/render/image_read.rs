//! Reading images (`Image::read`, the `--reference` of `render` and the reference cache of render
//! tables): a NaN or infinite pixel is an input error naming the file, the pixel and the
//! channel, because it would make every RMSE against the image NaN or infinite.

use image::{ImageFormat, Rgb, Rgb32FImage};
use std::path::Path;
use workbench::render::Image;

/// Writes a 4×3 OpenEXR (32-bit float RGB) with `bad` at pixel (x, y), channel `c`, through
/// the same `image` crate the workbench reads with.
fn write_exr(path: &Path, bad: Option<(u32, u32, usize, f32)>) {
    let mut buf = Rgb32FImage::from_fn(4, 3, |x, y| Rgb([0.1 * x as f32, 0.2 * y as f32, 0.5]));
    if let Some((x, y, c, v)) = bad {
        buf.get_pixel_mut(x, y).0[c] = v;
    }
    image::DynamicImage::ImageRgb32F(buf)
        .save_with_format(path, ImageFormat::OpenExr)
        .unwrap();
}

#[test]
fn a_non_finite_pixel_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ((2, 1, 1, f32::NAN), "pixel (2, 1) channel g is NaN"),
        ((0, 2, 2, f32::NEG_INFINITY), "pixel (0, 2) channel b is -inf"),
        ((3, 0, 0, f32::INFINITY), "pixel (3, 0) channel r is inf"),
    ];
    for (bad, needle) in cases {
        let path = dir.path().join("ref.exr");
        write_exr(&path, Some(bad));
        let e = Image::read(&path, "--reference").unwrap_err().to_string();
        let want = format!(
            "--reference {}: {needle}; an image must hold finite values",
            path.display()
        );
        assert_eq!(e, want);
    }
}

/// The first bad value in reading order (rows from the top, then pixels, then channels) is the
/// one named.
#[test]
fn the_first_non_finite_value_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.exr");
    let mut buf = Rgb32FImage::from_pixel(4, 3, Rgb([1.0, 1.0, 1.0]));
    buf.get_pixel_mut(1, 2).0[0] = f32::NAN;
    buf.get_pixel_mut(3, 1).0[2] = f32::INFINITY;
    image::DynamicImage::ImageRgb32F(buf)
        .save_with_format(&path, ImageFormat::OpenExr)
        .unwrap();
    let e = Image::read(&path, "reference cache").unwrap_err().to_string();
    assert!(e.contains("pixel (3, 1) channel b is inf"), "{e}");
}

#[test]
fn a_finite_image_still_reads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.exr");
    write_exr(&path, None);
    let img = Image::read(&path, "--reference").unwrap();
    assert_eq!((img.width, img.height), (4, 3));
    assert_eq!(img.data[4 + 2], [(0.1f32 * 2.0) as f64, 0.2f32 as f64, 0.5]);
    // Negative values are finite and stay allowed (BMC renders can have them).
    write_exr(&path, Some((1, 1, 0, -0.25)));
    assert_eq!(Image::read(&path, "--reference").unwrap().data[5][0], -0.25);
}
