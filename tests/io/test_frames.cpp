#include <limits>
#include <vector>

#include <catch2/catch.hpp>
#include <opencv2/core.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/frames.hpp"

using namespace shearzone;

TEST_CASE("frames held in memory stream in order with times k / fps, the caller's arrays unchanged",
          "[io][frames]") {
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 3; ++k) frames.push_back(cv::Mat(4, 5, CV_8UC1, cv::Scalar(10 * k)));
  auto source = io::frames_from_memory(frames, 25.0, "arrays");
  io::Frame f;
  for (int k = 0; k < 3; ++k) {
    REQUIRE(source->next(f));
    CHECK(f.index == k);
    CHECK(f.t_s == k / 25.0);
    CHECK(f.gray.at<std::uint8_t>(2, 3) == 10 * k);
  }
  CHECK_FALSE(source->next(f));
}

TEST_CASE("float frames take grey levels 0..1 inclusive, and nothing else", "[io][frames]") {
  const auto pair_of = [](float value) {
    cv::Mat a(4, 4, CV_32FC1, cv::Scalar(0.5F));
    cv::Mat b = a.clone();
    b.at<float>(1, 2) = value;
    return std::vector<cv::Mat>{a, b};
  };
  // 1 is white and 0 black: both ends belong to the range.
  CHECK_NOTHROW(io::frames_from_memory(pair_of(1.0F), 25.0, "arrays"));
  CHECK_NOTHROW(io::frames_from_memory(pair_of(0.0F), 25.0, "arrays"));
  CHECK_THROWS_WITH(io::frames_from_memory(pair_of(std::nextafter(1.0F, 2.0F)), 25.0, "arrays"),
                    "arrays#1: float grey levels outside 0..1 (or not finite); expected 0..1");
  CHECK_THROWS_AS(io::frames_from_memory(pair_of(-1e-7F), 25.0, "arrays"), InputError);
  CHECK_THROWS_AS(io::frames_from_memory(pair_of(std::numeric_limits<float>::quiet_NaN()), 25.0, "arrays"),
                  InputError);
}

TEST_CASE("frames in memory that are empty, of another size or type, or too few are refused by index",
          "[io][frames]") {
  const cv::Mat a(4, 4, CV_8UC1, cv::Scalar(1));
  CHECK_THROWS_WITH(io::frames_from_memory({a, cv::Mat()}, 25.0, "arrays"),
                    "arrays#1: an empty array (0 px); expected a 2-D grey image");
  CHECK_THROWS_WITH(io::frames_from_memory({a, cv::Mat(4, 5, CV_8UC1)}, 25.0, "arrays"),
                    Catch::Contains("arrays#1: 5x4 px") && Catch::Contains("frames must match"));
  CHECK_THROWS_WITH(io::frames_from_memory({a, cv::Mat(4, 4, CV_16UC1)}, 25.0, "arrays"),
                    Catch::Contains("frames must match"));
  CHECK_THROWS_WITH(io::frames_from_memory({a, cv::Mat(4, 4, CV_8UC3)}, 25.0, "arrays"),
                    "arrays#1: expected a 2-D array of uint8, uint16 or float32 grey levels");
  CHECK_THROWS_WITH(io::frames_from_memory({a}, 25.0, "arrays"), "arrays: 1 frame: a pair needs two");
  CHECK_THROWS_AS(io::frames_from_memory({a, a}, 0.0, "arrays"), ConfigError);
}
