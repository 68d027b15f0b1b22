#include "shearzone/io/image.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <utility>
#include <cstdlib>
#include <climits>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"
#include "stderr_silencer.hpp"

namespace shearzone::io {
namespace {

/// The extension, ASCII-lower-cased (encode_image needs it as text: the encoder and
/// its messages take it; is_*_extension use io::has_extension).
std::string lower_ext(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

enum class Format { kPng, kJpeg, kBmp, kTiff, kPnm, kWebp, kJpeg2000, kHdr, kExr, kUnknown };

/// The format from the first bytes (magic numbers), whatever the extension says.
Format sniff(std::string_view b) {
  auto u = [&](std::size_t i) { return static_cast<unsigned char>(b[i]); };
  if (b.size() >= 8 && u(0) == 0x89 && b.compare(1, 3, "PNG") == 0) return Format::kPng;
  if (b.size() >= 3 && u(0) == 0xFF && u(1) == 0xD8 && u(2) == 0xFF) return Format::kJpeg;
  if (b.size() >= 2 && b[0] == 'B' && b[1] == 'M') return Format::kBmp;
  if (b.size() >= 4 && ((b[0] == 'I' && b[1] == 'I' && u(2) == 42 && u(3) == 0) ||
                        (b[0] == 'M' && b[1] == 'M' && u(2) == 0 && u(3) == 42)))
    return Format::kTiff;
  // Netpbm: P1..P6 followed by white space (PBM, PGM, PPM; ASCII or binary).
  if (b.size() >= 3 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6' && std::isspace(u(2)))
    return Format::kPnm;
  if (b.size() >= 12 && b.compare(0, 4, "RIFF") == 0 && b.compare(8, 4, "WEBP") == 0) return Format::kWebp;
  if ((b.size() >= 12 && b.compare(4, 8, "jP  \r\n\x87\n") == 0) ||
      (b.size() >= 4 && u(0) == 0xFF && u(1) == 0x4F && u(2) == 0xFF && u(3) == 0x51))
    return Format::kJpeg2000;
  if (b.size() >= 6 && (b.compare(0, 10, "#?RADIANCE") == 0 || b.compare(0, 6, "#?RGBE") == 0))
    return Format::kHdr;
  if (b.size() >= 4 && u(0) == 0x76 && u(1) == 0x2F && u(2) == 0x31 && u(3) == 0x01) return Format::kExr;
  return Format::kUnknown;
}

constexpr const char* kDecodedFormats =
    "PNG, JPEG, TIFF, BMP, PGM/PPM/PBM, WebP, JPEG 2000";

using detail::StderrSilencer;

/// Width and height from the header of PNG, BMP, Netpbm, JPEG, TIFF, WebP and JPEG 2000
/// files (0, 0 when not found).
std::pair<long long, long long> header_size(const std::string& b, Format f) {
  auto u = [&](std::size_t i) -> long long { return i < b.size() ? static_cast<unsigned char>(b[i]) : 0; };
  switch (f) {
    case Format::kPng:  // IHDR: width, height big-endian at bytes 16 and 20
      if (b.size() >= 24)
        return {(u(16) << 24) | (u(17) << 16) | (u(18) << 8) | u(19), (u(20) << 24) | (u(21) << 16) | (u(22) << 8) | u(23)};
      break;
    case Format::kBmp:  // BITMAPINFOHEADER: int32 width, height little-endian at 18, 22
      if (b.size() >= 26) {
        const auto w = static_cast<std::int32_t>(u(18) | (u(19) << 8) | (u(20) << 16) | (u(21) << 24));
        const auto h = static_cast<std::int32_t>(u(22) | (u(23) << 8) | (u(24) << 16) | (u(25) << 24));
        return {std::llabs(w), std::llabs(h)};
      }
      break;
    case Format::kPnm: {  // "P5 <w> <h> ..." with comments; like OpenCV's reader, any
      // other non-digit separates numbers (found by fuzzing: "P2 699999+999=..." decoded
      // as 699999 x 999 px)
      std::size_t i = 2;
      long long v[2] = {0, 0};
      for (int k = 0; k < 2; ++k) {
        while (i < b.size() && !std::isdigit(static_cast<unsigned char>(b[i]))) {
          if (b[i] == '#')
            while (i < b.size() && b[i] != '\n') ++i;
          else
            ++i;
        }
        while (i < b.size() && std::isdigit(static_cast<unsigned char>(b[i])) && v[k] < (1LL << 40))
          v[k] = v[k] * 10 + (b[i++] - '0');
      }
      return {v[0], v[1]};
    }
    case Format::kJpeg: {  // the first SOFn marker: height, width big-endian
      std::size_t i = 2;
      while (i + 9 < b.size()) {
        if (u(i) != 0xFF) {
          ++i;
          continue;
        }
        const long long m = u(i + 1);
        if (m == 0xD8 || m == 0x01 || (m >= 0xD0 && m <= 0xD7) || m == 0xFF) {
          ++i;
          continue;
        }
        if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC)
          return {(u(i + 7) << 8) | u(i + 8), (u(i + 5) << 8) | u(i + 6)};
        i += 2 + static_cast<std::size_t>((u(i + 2) << 8) | u(i + 3));
      }
      break;
    }
    case Format::kTiff: {  // IFD 0: tags 256 (width) and 257 (height), SHORT or LONG
      const bool le = b[0] == 'I';
      auto rd = [&](std::size_t at, int n) -> long long {
        long long v = 0;
        for (int k = 0; k < n; ++k) v |= u(at + static_cast<std::size_t>(le ? k : n - 1 - k)) << (8 * k);
        return v;
      };
      const auto ifd = static_cast<std::size_t>(rd(4, 4));
      if (ifd + 2 > b.size()) break;
      const auto entries = static_cast<std::size_t>(rd(ifd, 2));
      long long w = 0, h = 0;
      for (std::size_t e = 0; e < entries && ifd + 2 + 12 * (e + 1) <= b.size(); ++e) {
        const std::size_t at = ifd + 2 + 12 * e;
        const long long tag = rd(at, 2), type = rd(at + 2, 2);
        const long long v = type == 3 ? rd(at + 8, 2) : rd(at + 8, 4);
        if (tag == 256) w = v;
        if (tag == 257) h = v;
      }
      return {w, h};
    }
    case Format::kWebp:  // the first chunk: VP8X canvas, VP8 frame or VP8L header
      if (b.size() >= 30 && b.compare(12, 4, "VP8X") == 0)
        return {1 + (u(24) | (u(25) << 8) | (u(26) << 16)), 1 + (u(27) | (u(28) << 8) | (u(29) << 16))};
      if (b.size() >= 30 && b.compare(12, 4, "VP8 ") == 0)
        return {(u(26) | (u(27) << 8)) & 0x3FFF, (u(28) | (u(29) << 8)) & 0x3FFF};
      if (b.size() >= 25 && b.compare(12, 4, "VP8L") == 0) {
        const long long bits = u(21) | (u(22) << 8) | (u(23) << 16) | (u(24) << 24);
        return {1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)};
      }
      break;
    case Format::kJpeg2000: {
      // The codestream's SIZ marker segment (FF 51, right after SOC FF 4F; in a JP2 file
      // inside the jp2c box): Lsiz, Rsiz, then Xsiz, Ysiz, XOsiz, YOsiz, big-endian.
      // The image is (Xsiz - XOsiz) x (Ysiz - YOsiz) (Csiz components follow: see
      // check_j2k_layout). Without this check a forged header lets OpenJPEG allocate
      // gigabytes.
      const std::size_t at = b.find("\xFF\x4F\xFF\x51");
      if (at == std::string::npos || at + 42 > b.size()) break;
      auto be32 = [&](std::size_t i) { return (u(i) << 24) | (u(i + 1) << 16) | (u(i + 2) << 8) | u(i + 3); };
      const std::size_t siz = at + 4;  // Lsiz
      const long long xs = be32(siz + 4), ys = be32(siz + 8), xo = be32(siz + 12), yo = be32(siz + 16);
      if (xs <= xo || ys <= yo) break;  // OpenJPEG refuses an empty image itself
      return {xs - xo, ys - yo};
    }
    default: break;
  }
  return {0, 0};
}

/// Refuses JPEG 2000 headers whose decoding would cost far more than the image: more
/// than 4 components (each decoded at full size) or more tiles than the standard's
/// 65535 (tiny tiles over a large canvas: per-tile structures by the million).
void check_j2k_layout(const std::string& b, const std::string& source) {
  const std::size_t at = b.find("\xFF\x4F\xFF\x51");
  if (at == std::string::npos || at + 42 > b.size()) return;
  auto u = [&](std::size_t i) -> long long { return static_cast<unsigned char>(b[i]); };
  auto be32 = [&](std::size_t i) { return (u(i) << 24) | (u(i + 1) << 16) | (u(i + 2) << 8) | u(i + 3); };
  const long long comps = (u(at + 40) << 8) | u(at + 41);
  if (comps > 4)
    throw InputError(fmt::format("{}: a JPEG 2000 image with {} components; expected 1 to 4 (grey, "
                                 "colour, colour + alpha)",
                                 source, comps));
  const long long xs = be32(at + 8), ys = be32(at + 12), xt = be32(at + 24), yt = be32(at + 28);
  const long long xto = be32(at + 32), yto = be32(at + 36);
  if (xt > 0 && yt > 0 && xs > xto && ys > yto) {
    const long long tiles = ((xs - xto + xt - 1) / xt) * ((ys - yto + yt - 1) / yt);
    if (tiles > 65535)
      throw InputError(fmt::format("{}: a JPEG 2000 image of {} tiles; expected at most 65535", source, tiles));
  }
}

/// Checks the end marker of formats whose decoders may accept truncated data.
void check_complete(const std::string& b, Format f, const std::string& source) {
  auto u = [&](std::size_t i) { return static_cast<unsigned char>(b[i]); };
  switch (f) {
    case Format::kPng: {
      // The file ends with the IEND chunk: length 0, "IEND", CRC AE 42 60 82.
      if (b.size() < 12 || b.find("IEND", b.size() - 12) == std::string::npos)
        throw InputError(fmt::format("{}: truncated PNG (no IEND chunk at the end)", source));
      break;
    }
    case Format::kJpeg: {
      // EOI marker FF D9 near the end (trailing padding is tolerated). In the
      // entropy-coded data FF is always followed by 00 or a restart marker, so FF D9
      // only occurs as the end-of-image marker.
      const std::size_t from = b.size() > 1024 ? b.size() - 1024 : 0;
      const bool has_eoi = b.find("\xFF\xD9", from) != std::string::npos;
      if (!has_eoi)
        throw InputError(fmt::format("{}: truncated JPEG (no end-of-image marker)", source));
      break;
    }
    case Format::kBmp: {
      if (b.size() < 6) throw InputError(fmt::format("{}: truncated BMP header", source));
      const std::uint32_t declared = u(2) | (u(3) << 8) | (u(4) << 16) |
                                     (static_cast<std::uint32_t>(u(5)) << 24);
      if (declared > b.size())
        throw InputError(fmt::format("{}: truncated BMP: header declares {} bytes, file has {}",
                                     source, declared, b.size()));
      break;
    }
    default: break;
  }
}

}  // namespace

void configure_decoders() {
  ::setenv("OPENCV_FFMPEG_LOGLEVEL", "-8", 0);  // AV_LOG_QUIET
  ::setenv("OPENCV_LOG_LEVEL", "SILENT", 0);
}

void check_image_size(int width, int height, const std::string& source) {
  if (width > kMaxImageSide || height > kMaxImageSide ||
      static_cast<double>(width) * static_cast<double>(height) > kMaxImagePixels)
    throw InputError(fmt::format("{}: {} x {} px: expected at most {} px a side and {:.0e} pixels "
                                 "(checked before decoding)",
                                 source, width, height, kMaxImageSide, kMaxImagePixels));
}

bool is_image_extension(const std::filesystem::path& path) {
  for (const char* x : {".png", ".tif", ".tiff", ".bmp", ".jpg", ".jpeg"})
    if (has_extension(path, x)) return true;
  return false;
}

bool is_readable_image_extension(const std::filesystem::path& path) {
  for (const char* x : {".png", ".tif", ".tiff", ".bmp", ".dib", ".jpg", ".jpeg", ".jpe", ".pgm", ".ppm",
                        ".pbm", ".pnm", ".pxm", ".webp", ".jp2", ".j2k"})
    if (has_extension(path, x)) return true;
  return false;
}

bool looks_like_image(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char head[16] = {};
  in.read(head, sizeof(head));
  const Format f = sniff(std::string_view(head, static_cast<std::size_t>(in.gcount())));
  return f != Format::kUnknown;
}

const char* decoded_image_formats() { return kDecodedFormats; }

GreyMode grey_mode_from_name(const std::string& name) {
  return core::enum_from_name(
      name, {GreyMode::kLuma, GreyMode::kMean, GreyMode::kRed, GreyMode::kGreen, GreyMode::kBlue}, grey_mode_name,
      "grey conversion");
}

const char* grey_mode_name(GreyMode mode) {
  switch (mode) {
    case GreyMode::kLuma: return "luma";
    case GreyMode::kMean: return "mean";
    case GreyMode::kRed: return "red";
    case GreyMode::kGreen: return "green";
    case GreyMode::kBlue: return "blue";
  }
  return "?";
}

cv::Mat to_gray(const cv::Mat& image, GreyMode mode) {
  if (image.channels() == 1) return image;
  if (image.channels() != 3 && image.channels() != 4)
    throw InputError(fmt::format("image has {} channels; expected 1, 3 or 4", image.channels()));
  cv::Mat grey;
  switch (mode) {
    case GreyMode::kLuma:
      cv::cvtColor(image, grey, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
      break;
    case GreyMode::kMean: {
      std::vector<cv::Mat> ch;
      cv::split(image, ch);
      cv::Mat acc;
      cv::add(ch[0], ch[1], acc, cv::noArray(), CV_32F);
      cv::add(acc, ch[2], acc, cv::noArray(), CV_32F);
      acc.convertTo(grey, image.depth(), 1.0 / 3.0);
      break;
    }
    case GreyMode::kRed: cv::extractChannel(image, grey, 2); break;  // OpenCV order: B, G, R
    case GreyMode::kGreen: cv::extractChannel(image, grey, 1); break;
    case GreyMode::kBlue: cv::extractChannel(image, grey, 0); break;
  }
  return grey;
}

cv::Mat decode_image_gray(const std::string& bytes, const std::string& source, int* bit_depth,
                          GreyMode mode) {
  const Format f = sniff(bytes);
  if (f == Format::kUnknown)
    throw InputError(fmt::format("{}: not an image: its first bytes match none of the formats read "
                                 "({})",
                                 source, kDecodedFormats));
  if (f == Format::kHdr || f == Format::kExr)
    throw InputError(fmt::format("{}: a floating-point {} image; expected 8- or 16-bit samples ({})",
                                 source, f == Format::kHdr ? "Radiance HDR" : "OpenEXR", kDecodedFormats));
  // OpenCV tries its decoders in turn: one that rejects a malformed header of the
  // sniffed format hands the bytes on, and GDCM takes anything with "DICM" at byte 128
  // (a DICOM preamble), then aborts the process on the rest (found by fuzzing: a broken
  // WebP header). No image read here has those bytes there but by a 1 in 4e9 chance.
  if (bytes.size() >= 132 && bytes.compare(128, 4, "DICM") == 0)
    throw InputError(fmt::format("{}: bytes 128-131 read \"DICM\" (a DICOM preamble); DICOM is not read "
                                 "(expected {})",
                                 source, kDecodedFormats));
  check_complete(bytes, f, source);
  {
    const auto [w, h] = header_size(bytes, f);
    if (w > 0 && h > 0)
      check_image_size(static_cast<int>(std::min<long long>(w, INT32_MAX)),
                       static_cast<int>(std::min<long long>(h, INT32_MAX)), source);
  }
  if (f == Format::kJpeg2000) check_j2k_layout(bytes, source);
  cv::Mat raw;
  try {
    std::vector<uchar> buf(bytes.begin(), bytes.end());
    // libpng and libtiff print their own complaints ("libpng error: IHDR: CRC error") on
    // stderr; the error thrown below names the file instead.
    const StderrSilencer quiet;
    raw = cv::imdecode(buf, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("{}: cannot decode image: {}", source, excerpt(std::string_view(e.what()).substr(0, std::string_view(e.what()).find('\n')), 300)));
  }
  if (raw.empty())
    throw InputError(fmt::format("{}: cannot decode image (corrupt or truncated)", source));
  if (raw.depth() != CV_8U && raw.depth() != CV_16U)
    throw InputError(fmt::format("{}: {}-byte samples are not supported; expected an 8- or "
                                 "16-bit image",
                                 source, raw.elemSize1()));
  if (bit_depth) *bit_depth = raw.depth() == CV_8U ? 8 : 16;
  try {
    return to_gray(raw, mode);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

cv::Mat read_image_gray(const std::filesystem::path& path, int* bit_depth, GreyMode mode) {
  return decode_image_gray(read_file_bytes(path, "file"), path.string(), bit_depth, mode);
}

std::string encode_image(const cv::Mat& image, const std::filesystem::path& path) {
  const std::string e = lower_ext(path);
  if (!is_image_extension(path))
    throw ConfigError(fmt::format("{}: unsupported image extension \"{}\"; expected one of: "
                                  ".png, .tif, .tiff, .bmp, .jpg, .jpeg",
                                  path.string(), e));
  if (image.depth() != CV_8U && image.depth() != CV_16U)
    throw ConfigError(fmt::format("{}: cannot write a {}-byte image; expected 8 or 16 bits",
                                  path.string(), image.elemSize1()));
  if (image.depth() == CV_16U && (e == ".jpg" || e == ".jpeg" || e == ".bmp"))
    throw ConfigError(fmt::format("{}: {} cannot hold 16-bit images; use .png or .tif",
                                  path.string(), e));
  std::vector<int> params;
  if (e == ".jpg" || e == ".jpeg") params = {cv::IMWRITE_JPEG_QUALITY, 95};
  if (e == ".png") params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  std::vector<uchar> buf;
  if (!cv::imencode(e, image, buf, params))
    throw InputError(fmt::format("{}: image encoding failed", path.string()));
  return std::string(buf.begin(), buf.end());
}

void write_image(const std::filesystem::path& path, const cv::Mat& image, bool force) {
  const std::string bytes = encode_image(image, path);
  AtomicOutput out(path, force);
  out.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.commit();
}

}  // namespace shearzone::io
