// shearzone/io/image.hpp: reading and writing still images (OpenCV).
//
// Formats: PNG, TIFF, BMP and JPEG, 8 or 16 bits per sample. Colour images are
// converted to grey (ITU-R BT.601 luma, OpenCV's cvtColor weights), keeping the
// bit depth. Pixel (row i, column j) has its centre at (x, y) = (j, i).
//
// Truncated or undecodable files are an InputError naming the file. Because some
// decoders quietly return a partly grey image for a truncated file (libjpeg),
// the reader also checks each format's end marker (PNG IEND chunk, JPEG EOI,
// BMP declared size) before decoding.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace shearzone::io {

/// How colour becomes grey: ITU-R BT.601 luma (default), the mean of the channels, or
/// one channel (for a coloured light or a stained sample).
enum class GreyMode { kLuma, kMean, kRed, kGreen, kBlue };
/// "luma", "mean", "red", "green", "blue"; ConfigError lists them for another name.
GreyMode grey_mode_from_name(const std::string& name);
const char* grey_mode_name(GreyMode mode);

/// Reads an image as single-channel grey, CV_8U or CV_16U as stored.
/// `bit_depth` (optional) receives 8 or 16.
cv::Mat read_image_gray(const std::filesystem::path& path, int* bit_depth = nullptr,
                        GreyMode mode = GreyMode::kLuma);

/// Decodes an in-memory image file (`source` names it in messages).
cv::Mat decode_image_gray(const std::string& bytes, const std::string& source,
                          int* bit_depth = nullptr, GreyMode mode = GreyMode::kLuma);

/// Colour (3 or 4 channels, BGR order) to grey; grey images pass through.
cv::Mat to_gray(const cv::Mat& image, GreyMode mode = GreyMode::kLuma);

/// Encodes `image` (CV_8U or CV_16U, 1 or 3 channels) in the format given by the
/// extension of `path` (.png, .tif/.tiff, .bmp, .jpg/.jpeg). JPEG and BMP are
/// 8-bit only. Throws ConfigError for an unsupported extension or depth.
std::string encode_image(const cv::Mat& image, const std::filesystem::path& path);

/// Writes an image atomically (temporary file + rename); refuses to overwrite an
/// existing file unless `force`.
void write_image(const std::filesystem::path& path, const cv::Mat& image, bool force);

/// Largest frame accepted, checked from the file's header before any pixel is decoded
/// (a 1 MB PNG can declare 30000 x 30000 px): at most kMaxImageSide px a side and
/// kMaxImagePixels pixels. Images and video frames beyond are InputError.
inline constexpr int kMaxImageSide = 32768;
inline constexpr double kMaxImagePixels = 1e8;
/// Throws InputError naming `source` if width x height is beyond the limits above.
void check_image_size(int width, int height, const std::string& source);

/// Sets the process environment the decoders read (only variables the user has not
/// set): FFmpeg and OpenCV log levels silent (our one error line says what matters).
/// (OpenCV's own pixel limit, OPENCV_IO_MAX_IMAGE_PIXELS, is read when the library
/// loads, so it cannot be set here; check_image_size reads the headers instead.)
/// Call once, before any image or video is opened.
void configure_decoders();

/// True if the extension is one of the still-image formats above (writable).
bool is_image_extension(const std::filesystem::path& path);

/// True if the extension is one of the formats read: those above and .pgm/.ppm/
/// .pbm/.pnm/.pxm, .webp, .jp2/.j2k, .dib, .jpe.
bool is_readable_image_extension(const std::filesystem::path& path);

/// True if the file's first bytes are the magic number of a format read (any
/// extension); false if it cannot be opened.
bool looks_like_image(const std::filesystem::path& path);

/// The formats read, for messages: "PNG, JPEG, TIFF, ...".
const char* decoded_image_formats();

}  // namespace shearzone::io
