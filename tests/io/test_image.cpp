#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/image.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {
cv::Mat ramp(int depth) {
  cv::Mat m(32, 48, depth);
  for (int i = 0; i < m.rows; ++i)
    for (int j = 0; j < m.cols; ++j) {
      const int v = (i * 48 + j) * 37 % (depth == CV_8U ? 256 : 65536);
      if (depth == CV_8U) m.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(v);
      else m.at<std::uint16_t>(i, j) = static_cast<std::uint16_t>(v);
    }
  return m;
}
}  // namespace

TEST_CASE("lossless formats round-trip 8- and 16-bit grey images exactly", "[io][image]") {
  testing::TempDir dir("img");
  for (const std::string ext : {".png", ".tif", ".bmp"}) {
    for (int depth : {CV_8U, CV_16U}) {
      if (ext == ".bmp" && depth == CV_16U) continue;  // BMP is 8-bit
      const auto path = dir / ("a" + std::to_string(depth) + ext);
      const cv::Mat m = ramp(depth);
      io::write_image(path, m, false);
      int bits = 0;
      const cv::Mat back = io::read_image_gray(path, &bits);
      CHECK(bits == (depth == CV_8U ? 8 : 16));
      REQUIRE(back.type() == m.type());
      CHECK(cv::norm(back, m, cv::NORM_INF) == 0.0);
    }
  }
}

TEST_CASE("every lossless format OpenCV decodes is read, by content when the name is unknown",
          "[io][image]") {
  testing::TempDir dir("fmt");
  const cv::Mat m = ramp(CV_8U);
  // Lossless writers of Debian's OpenCV 4.6 (WebP at quality > 100 is lossless).
  const std::vector<std::pair<std::string, std::vector<int>>> formats = {
      {".pgm", {}}, {".pnm", {}}, {".webp", {cv::IMWRITE_WEBP_QUALITY, 101}},
      {".jp2", {cv::IMWRITE_JPEG2000_COMPRESSION_X1000, 1000}}, {".tiff", {}}};
  for (const auto& [ext, params] : formats) {
    if (!cv::haveImageWriter(ext)) continue;
    INFO(ext);
    const auto path = dir / ("a" + ext);
    REQUIRE(cv::imwrite(path.string(), m, params));
    CHECK(io::is_readable_image_extension(path));
    CHECK(io::looks_like_image(path));
    CHECK(cv::norm(io::read_image_gray(path), m, cv::NORM_INF) == 0.0);
    // The same bytes under a name that says nothing: recognised by content.
    const auto anon = dir / ("a" + ext.substr(1) + ".frame");
    fs::copy_file(path, anon);
    CHECK_FALSE(io::is_readable_image_extension(anon));
    CHECK(io::looks_like_image(anon));
    CHECK(cv::norm(io::read_image_gray(anon), m, cv::NORM_INF) == 0.0);
  }
  // A colour PPM becomes grey.
  cv::Mat colour;
  cv::cvtColor(m, colour, cv::COLOR_GRAY2BGR);
  REQUIRE(cv::imwrite((dir / "c.ppm").string(), colour));
  CHECK(cv::norm(io::read_image_gray(dir / "c.ppm"), m, cv::NORM_INF) == 0.0);
  // Not an image: the message names the file and the formats read.
  testing::write_file(dir / "notes.txt", "hello, not pixels\n");
  CHECK_FALSE(io::looks_like_image(dir / "notes.txt"));
  CHECK_THROWS_WITH(io::read_image_gray(dir / "notes.txt"),
                    Contains("notes.txt: not an image") && Contains("PGM/PPM/PBM"));
}

TEST_CASE("JPEG round-trips within its compression error", "[io][image]") {
  testing::TempDir dir("img");
  cv::Mat m(64, 64, CV_8U);
  cv::GaussianBlur(ramp(CV_8U)(cv::Rect(0, 0, 32, 32)), m, cv::Size(3, 3), 0);  // smooth input
  cv::resize(m, m, cv::Size(64, 64));
  io::write_image(dir / "a.jpg", m, false);
  const cv::Mat back = io::read_image_gray(dir / "a.jpg");
  // Quality 95 on smooth content: a mean error of a few grey levels at most.
  CHECK(cv::norm(back, m, cv::NORM_L1) / m.total() < 4.0);
}

TEST_CASE("colour images are converted to grey", "[io][image]") {
  testing::TempDir dir("img");
  cv::Mat colour(8, 8, CV_8UC3, cv::Scalar(0, 0, 255));  // pure red (BGR)
  io::write_image(dir / "red.png", colour, false);
  const cv::Mat g = io::read_image_gray(dir / "red.png");
  REQUIRE(g.channels() == 1);
  CHECK(g.at<std::uint8_t>(0, 0) == 76);  // BT.601: 0.299 * 255
}

TEST_CASE("truncated and undecodable images are input errors naming the file", "[io][image]") {
  testing::TempDir dir("img");
  const cv::Mat m = ramp(CV_8U);
  for (const std::string ext : {".png", ".jpg", ".bmp", ".tif"}) {
    const auto path = dir / ("t" + ext);
    io::write_image(path, m, false);
    std::filesystem::resize_file(path, std::filesystem::file_size(path) * 2 / 3);
    CHECK_THROWS_MATCHES(io::read_image_gray(path), InputError,
                         Catch::Matchers::Predicate<InputError>([&](const InputError& e) {
                           return std::string(e.what()).find(path.string()) != std::string::npos;
                         }));
  }
  testing::write_file(dir / "x.png", "this is not an image");
  CHECK_THROWS_WITH(io::read_image_gray(dir / "x.png"), Contains("not an image"));
  CHECK_THROWS_WITH(io::read_image_gray(dir / "none.png"), Contains("none.png: no such file"));
}

TEST_CASE("JPEG 2000 headers that would cost gigabytes are refused before decoding", "[io][image]") {
  if (!cv::haveImageWriter(".jp2")) return;
  testing::TempDir dir("j2k");
  REQUIRE(cv::imwrite((dir / "a.jp2").string(), ramp(CV_8U), {cv::IMWRITE_JPEG2000_COMPRESSION_X1000, 1000}));
  const std::string good = testing::read_file(dir / "a.jp2");
  const std::size_t at = good.find("\xFF\x4F\xFF\x51");
  REQUIRE(at != std::string::npos);
  auto forge = [&](std::size_t offset, std::uint32_t value, int bytes) {
    std::string b = good;
    for (int k = 0; k < bytes; ++k)
      b[at + offset + static_cast<std::size_t>(k)] = static_cast<char>((value >> (8 * (bytes - 1 - k))) & 0xFF);
    return b;
  };
  CHECK(cv::norm(io::decode_image_gray(good, "a.jp2"), ramp(CV_8U), cv::NORM_INF) == 0.0);
  // Xsiz = Ysiz = 40000: a canvas of 1.6e9 px (OpenCV's own limit is 2^30).
  std::string big = forge(8, 40000, 4);
  big = std::string(big).replace(at + 12, 4, forge(12, 40000, 4).substr(at + 12, 4));
  CHECK_THROWS_WITH(io::decode_image_gray(big, "big.jp2"),
                    Contains("big.jp2: 40000 x 40000 px") && Contains("checked before decoding"));
  // 200 components, each decoded at full size.
  CHECK_THROWS_WITH(io::decode_image_gray(forge(40, 200, 2), "comps.jp2"),
                    Contains("comps.jp2: a JPEG 2000 image with 200 components; expected 1 to 4"));
  // 1 x 1 px tiles over a 4000 x 4000 px canvas: 16 million tiles.
  std::string tiles = forge(8, 4000, 4);
  tiles.replace(at + 12, 4, forge(12, 4000, 4).substr(at + 12, 4));
  tiles.replace(at + 24, 4, forge(24, 1, 4).substr(at + 24, 4));
  tiles.replace(at + 28, 4, forge(28, 1, 4).substr(at + 28, 4));
  CHECK_THROWS_WITH(io::decode_image_gray(tiles, "tiles.jp2"),
                    Contains("tiles.jp2: a JPEG 2000 image of 16000000 tiles; expected at most 65535"));
}

TEST_CASE("write_image refuses 16-bit JPEG and unknown extensions", "[io][image]") {
  testing::TempDir dir("img");
  CHECK_THROWS_AS(io::write_image(dir / "a.jpg", ramp(CV_16U), false), ConfigError);
  CHECK_THROWS_WITH(io::write_image(dir / "a.gif", ramp(CV_8U), false),
                    Contains("unsupported image extension \".gif\""));
  CHECK(testing::list_dir(dir.path()).empty());
}

TEST_CASE("colour to grey: luma, mean or one channel", "[io][image]") {
  testing::TempDir dir("img");
  cv::Mat colour(4, 4, CV_8UC3, cv::Scalar(30, 60, 240));  // B, G, R
  io::write_image(dir / "c.png", colour, false);
  auto grey = [&](io::GreyMode m) { return io::read_image_gray(dir / "c.png", nullptr, m).at<std::uint8_t>(1, 1); };
  CHECK(grey(io::GreyMode::kRed) == 240);
  CHECK(grey(io::GreyMode::kGreen) == 60);
  CHECK(grey(io::GreyMode::kBlue) == 30);
  CHECK(grey(io::GreyMode::kMean) == 110);
  CHECK(grey(io::GreyMode::kLuma) == 110);  // 0.299*240 + 0.587*60 + 0.114*30 = 110.6 -> 110 or 111
  CHECK_THROWS_WITH(io::grey_mode_from_name("grn"), Contains("expected one of: luma, mean, red, green, blue"));
}
