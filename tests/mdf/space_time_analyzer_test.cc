// Space-time analysis (Sec. 3.2, Fig. 5b) on synthetic sequences whose peak
// times are known exactly: each pixel sees a Gaussian pulse in time.
#include "mdf/space_time_analyzer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "calibration/laser_line.h"
#include "core/error.h"
#include "core/image_io.h"
#include "formats/sweep_analysis.h"
#include "tests/common/error_of.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::mdf {
namespace {

constexpr int kW = 16, kH = 8, kFrames = 40;

// Pixel p's true peak time: spread over [8, 30] with sub-frame offsets.
double TruePeak(int p) { return 8.0 + 22.0 * p / (kW * kH - 1); }

core::Image PulseFrame(int f, double amplitude, double sigma_frames, std::mt19937_64* rng, double noise) {
  std::normal_distribution<float> gauss(0.0f, static_cast<float>(noise));
  core::Image frame(kW, kH, 1);
  for (int p = 0; p < kW * kH; ++p) {
    const double d = f - TruePeak(p);
    float v = static_cast<float>(amplitude * std::exp(-d * d / (2 * sigma_frames * sigma_frames)));
    if (noise > 0) v += gauss(*rng);
    frame.data()[p] = std::min(1.0f, std::max(0.0f, v));
  }
  return frame;
}

double MaxTimeError(const formats::SweepAnalysis& a) {
  double worst = 0;
  for (int p = 0; p < kW * kH; ++p) worst = std::max(worst, std::abs(a.peak_time[p] - TruePeak(p)));
  return worst;
}

TEST(InterpolatePeakTest, ExactForGaussianSamplesAndUnevenSpacing) {
  auto g = [](double t) { return std::exp(-(t - 5.3) * (t - 5.3) / 2.0); };
  EXPECT_NEAR(calibration::InterpolatePeak(4, g(4), 5, g(5), 6, g(6)), 5.3, 1e-12);
  // Frame 6 dropped: neighbours 4 and 7.
  EXPECT_NEAR(calibration::InterpolatePeak(4, g(4), 5, g(5), 7, g(7)), 5.3, 1e-12);
  // A plateau has no vertex: the middle sample.
  EXPECT_EQ(calibration::InterpolatePeak(4, 1.0, 5, 1.0, 6, 1.0), 5.0);
}

// The streaming analyzer against the same rule applied to whole stored
// sequences: the first brightest frame, interpolated with the frames
// delivered just before and after it; the middle of the first longest
// saturated run; unknown below the threshold. Random pixels mix noise,
// pulses, a brighter second peak after a dip, saturated plateaus and
// maxima in consecutive frames; 120 pixels leave a partial 32-pixel block,
// and dropped frames make "before" and "after" span gaps.
TEST(SpaceTimeAnalyzerTest, StreamingMatchesTheWholeSequenceRule) {
  constexpr int kWidth = 40, kHeight = 3, kCount = 50, kPixels = kWidth * kHeight;
  const SpaceTimeOptions options;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<std::vector<float>> values(kPixels, std::vector<float>(kCount));
  for (int p = 0; p < kPixels; ++p) {
    const int kind = p % 5;
    for (int f = 0; f < kCount; ++f) {
      double v = 0.002 * uniform(rng);  // dark-pixel noise, below half the threshold
      if (kind >= 1) v += 0.6 * std::exp(-std::pow(f - (10 + p % 30), 2) / 4.0);
      if (kind == 2) v += 0.8 * std::exp(-std::pow(f - (25 + p % 20), 2) / 2.0);  // brighter, after a dip
      if (kind == 3 && f >= 20 && f < 20 + p % 4) v = 1.0;                        // a saturated run
      if (kind == 4) v = 0.003 + 0.01 * uniform(rng);                             // around the threshold
      values[p][f] = static_cast<float>(std::min(1.0, v));
    }
  }
  const std::vector<int> delivered = [] {
    std::vector<int> d;
    for (int f = 0; f < kCount; ++f) {
      if (f != 7 && f != 26 && f != 27) d.push_back(f);
    }
    return d;
  }();
  SpaceTimeAnalyzer analyzer(kWidth, kHeight, kCount, options);
  for (int f : delivered) {
    core::Image frame(kWidth, kHeight, 1);
    for (int p = 0; p < kPixels; ++p) frame.data()[p] = values[p][f];
    analyzer.AddFrame(f, frame);
  }
  const formats::SweepAnalysis a = analyzer.Result();
  for (int p = 0; p < kPixels; ++p) {
    std::size_t k_best = 0;
    for (std::size_t k = 1; k < delivered.size(); ++k) {
      if (values[p][delivered[k]] > values[p][delivered[k_best]]) k_best = k;
    }
    const float best = values[p][delivered[k_best]];
    if (best < options.threshold) {
      EXPECT_TRUE(std::isnan(a.peak_time[p])) << p;
      continue;
    }
    double expected = delivered[k_best];
    int run_first = -1, run_last = -2;
    for (std::size_t k = 0; k < delivered.size();) {
      std::size_t e = k;
      while (e < delivered.size() && values[p][delivered[e]] >= options.saturation) ++e;
      if (e > k && static_cast<int>(e - k) > run_last - run_first + 1) {
        run_first = static_cast<int>(k);
        run_last = static_cast<int>(e) - 1;
      }
      k = e > k ? e : k + 1;
    }
    if (best >= options.saturation) {
      expected = 0.5 * (delivered[run_first] + delivered[run_last]);
    } else if (k_best > 0 && k_best + 1 < delivered.size()) {
      const int b = delivered[k_best - 1], m = delivered[k_best], n = delivered[k_best + 1];
      expected = calibration::InterpolatePeak(b, values[p][b], m, values[p][m], n, values[p][n]);
    }
    EXPECT_NEAR(a.peak_time[p], expected, 1e-5) << "pixel " << p;
    EXPECT_EQ(a.peak_value[p], best) << "pixel " << p;
  }
}

TEST(SpaceTimeAnalyzerTest, SubFramePeakTimeWithNoise) {
  std::mt19937_64 rng(1);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  for (int f = 0; f < kFrames; ++f) analyzer.AddFrame(f, PulseFrame(f, 0.6, 1.2, &rng, 0.0));
  EXPECT_LT(MaxTimeError(analyzer.Result()), 1e-4);  // exact for a Gaussian in time

  SpaceTimeAnalyzer noisy(kW, kH, kFrames);
  for (int f = 0; f < kFrames; ++f) noisy.AddFrame(f, PulseFrame(f, 0.6, 1.2, &rng, 0.005));
  EXPECT_LT(MaxTimeError(noisy.Result()), 0.05);
}

TEST(SpaceTimeAnalyzerTest, BelowThresholdIsUnknown) {
  std::mt19937_64 rng(2);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames, {.threshold = 0.1f});
  for (int f = 0; f < kFrames; ++f) analyzer.AddFrame(f, PulseFrame(f, 0.08, 1.2, &rng, 0.005));
  const formats::SweepAnalysis a = analyzer.Result();
  for (int p = 0; p < kW * kH; ++p) EXPECT_TRUE(std::isnan(a.peak_time[p])) << p;
}

TEST(SpaceTimeAnalyzerTest, SaturatedStripeUsesTheMiddleOfThePlateau) {
  std::mt19937_64 rng(3);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  // Four times full scale: clipped over ~3-4 frames around the peak.
  for (int f = 0; f < kFrames; ++f) analyzer.AddFrame(f, PulseFrame(f, 4.0, 1.2, &rng, 0.0));
  // The plateau's middle is within half a frame of the true peak (the clipped
  // run is symmetric about it to within one frame's quantization).
  EXPECT_LE(MaxTimeError(analyzer.Result()), 0.5);
}

// Two pulses 12 frames apart in every pixel (a pixel seeing a near and a
// far surface), the brighter one first in even pixels and second in odd
// ones, frames 13 and 24 dropped: both times to sub-frame accuracy, each
// with its value; a pixel with one pulse has no second peak, and two
// pulses closer than min_peak_separation merge into one.
TEST(SpaceTimeAnalyzerTest, SecondPeakOfAPixelSeeingTwoSurfaces) {
  constexpr int kPixels = kW * kH;
  auto first_time = [](int p) { return 8.0 + 10.0 * p / (kPixels - 1); };
  auto pulse = [](double f, double t, double amplitude) {
    return amplitude * std::exp(-(f - t) * (f - t) / (2 * 1.2 * 1.2));
  };
  const SpaceTimeOptions options;
  for (const bool merged : {false, true}) {
    SpaceTimeAnalyzer analyzer(kW, kH, kFrames, options);
    const double gap = merged ? 3.0 : 12.0;
    for (int f = 0; f < kFrames; ++f) {
      if (f == 13 || f == 24) continue;
      core::Image frame(kW, kH, 1);
      for (int p = 0; p < kPixels; ++p) {
        const bool single = p % 7 == 0;
        const double bright = p % 2 == 0 ? 0.6 : 0.2, dim = p % 2 == 0 ? 0.2 : 0.6;
        frame.data()[p] =
            static_cast<float>(pulse(f, first_time(p), bright) + (single ? 0.0 : pulse(f, first_time(p) + gap, dim)));
      }
      analyzer.AddFrame(f, frame);
    }
    const formats::SweepAnalysis a = analyzer.Result();
    int seconds = 0;
    for (int p = 0; p < kPixels; ++p) {
      const double t1 = first_time(p), t2 = t1 + gap;
      if (p % 7 == 0) {  // one pulse: its tail 5 frames out is 1e-4, under the threshold
        EXPECT_TRUE(std::isnan(a.second_time[p])) << p << " " << a.second_time[p];
        EXPECT_EQ(a.second_value[p], 0.0f) << p;
        continue;
      }
      if (merged) {
        // One profile, its vertex between the two pulses (what is reported
        // second is the profile's own flank 5 frames out: resampling finds
        // that it continues no neighbour's surface).
        EXPECT_GT(a.peak_time[p], t1 - 0.5) << p;
        EXPECT_LT(a.peak_time[p], t2 + 0.5) << p;
        continue;
      }
      // A dropped frame next to a peak leaves a 3-frame-wide sample triple:
      // the Gaussian vertex is still exact.
      const double bright_time = p % 2 == 0 ? t1 : t2, dim_time = p % 2 == 0 ? t2 : t1;
      EXPECT_NEAR(a.peak_time[p], bright_time, 1e-3) << p;
      EXPECT_NEAR(a.second_time[p], dim_time, 1e-3) << p;
      // The sample nearest the dim pulse's top: at most a frame off it where
      // a neighbouring frame was dropped (0.2 exp(-1 / (2 1.2^2)) = 0.141).
      EXPECT_GE(a.second_value[p], 0.14f) << p;
      EXPECT_LE(a.second_value[p], 0.2f) << p;
      ++seconds;
    }
    if (!merged) {
      EXPECT_EQ(seconds, kPixels - (kPixels + 6) / 7);
    }
  }
}

TEST(SpaceTimeAnalyzerTest, WeakerGhostPeakIsIgnored) {
  std::mt19937_64 rng(4);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  for (int f = 0; f < kFrames; ++f) {
    core::Image frame = PulseFrame(f, 0.6, 1.2, &rng, 0.0);
    // An interreflection: a second, weaker pulse 6 frames later.
    const core::Image ghost = PulseFrame(f - 6, 0.3, 1.2, &rng, 0.0);
    for (std::size_t i = 0; i < frame.size(); ++i) frame.data()[i] += ghost.data()[i];
    analyzer.AddFrame(f, frame);
  }
  const formats::SweepAnalysis a = analyzer.Result();
  EXPECT_LT(MaxTimeError(a), 0.02);  // the ghost's tail barely shifts the vertex
  // It is kept as the second peak, for resampling to judge.
  for (int p = 0; p < kW * kH; ++p) EXPECT_NEAR(a.second_time[p], TruePeak(p) + 6, 0.3) << p;
}

TEST(SpaceTimeAnalyzerTest, DroppedFramesAreInterpolatedOverTheRealGap) {
  std::mt19937_64 rng(5);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  for (int f = 0; f < kFrames; ++f) {
    if (f == 15 || f == 22) continue;  // lost by the camera
    analyzer.AddFrame(f, PulseFrame(f, 0.6, 1.2, &rng, 0.0));
  }
  EXPECT_EQ(analyzer.frames_added(), kFrames - 2);
  // Pixels whose peak sits next to a dropped frame use the uneven spacing;
  // still exact for a Gaussian unless the dropped frame was the peak itself.
  EXPECT_LT(MaxTimeError(analyzer.Result()), 0.35);
}

TEST(SpaceTimeAnalyzerTest, RejectsBadFrames) {
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  EXPECT_THROW(analyzer.AddFrame(0, core::Image(kW + 1, kH, 1)), core::Error);
  EXPECT_THROW(analyzer.AddFrame(0, core::Image(kW, kH, 3)), core::Error);
  analyzer.AddFrame(3, core::Image(kW, kH, 1));
  EXPECT_THROW(analyzer.AddFrame(3, core::Image(kW, kH, 1)), core::Error);        // not increasing
  EXPECT_THROW(analyzer.AddFrame(kFrames, core::Image(kW, kH, 1)), core::Error);  // beyond the sweep
  EXPECT_THROW(SpaceTimeAnalyzer(0, kH, kFrames), core::Error);
  EXPECT_THROW(SpaceTimeAnalyzer(kW, kH, kFrames, {.threshold = 0.0f}), core::Error);
}

TEST(SweepAnalysisFileTest, RoundTripAndHostileInput) {
  std::mt19937_64 rng(6);
  SpaceTimeAnalyzer analyzer(kW, kH, kFrames);
  for (int f = 0; f < kFrames; ++f) analyzer.AddFrame(f, PulseFrame(f, 0.6, 1.2, &rng, 0.0));
  formats::SweepAnalysis a = analyzer.Result();
  a.peak_time[3] = std::nanf("");
  a.planes[2].normal = Eigen::Vector3d(0, 0.6, 0.8);
  a.planes[2].offset = -1.5;
  testing::TemporaryDirectory dir;
  const auto file = dir.path() / "sweep.json";
  formats::WriteSweepAnalysis(file, a);
  const formats::SweepAnalysis b = formats::ReadSweepAnalysis(file);
  ASSERT_EQ(b.width, kW);
  ASSERT_EQ(b.frame_count, kFrames);
  EXPECT_TRUE(std::isnan(b.peak_time[3]));
  EXPECT_EQ(b.peak_time[10], a.peak_time[10]);
  EXPECT_EQ(b.peak_value[10], a.peak_value[10]);
  EXPECT_TRUE(b.planes[2].valid());
  EXPECT_FALSE(b.planes[1].valid());
  EXPECT_NEAR(b.planes[2].offset, -1.5, 1e-12);
  a.second_time[5] = 17.25f;
  a.second_value[5] = 0.125f;
  formats::WriteSweepAnalysis(file, a);
  const formats::SweepAnalysis c = formats::ReadSweepAnalysis(file);
  EXPECT_EQ(c.second_time[5], 17.25f);
  EXPECT_EQ(c.second_value[5], 0.125f);
  EXPECT_TRUE(std::isnan(c.second_time[6]));

  // Version 1 (no second peaks: 2 channels) still reads, with none.
  core::Image v1(kW, kH, 2, 0.0f);
  v1.data()[2 * 10] = 4.5f;
  v1.data()[2 * 10 + 1] = 0.5f;
  v1.data()[2 * 11] = std::nanf("");
  core::WriteImage(dir.path() / "old.json.exr", v1, core::PixelEncoding::kFloat32);
  std::ofstream(dir.path() / "old.json") << R"({"format": "mesocap.sweep_analysis", "version": 1, "width": 16,
    "height": 8, "frame_count": 8, "image": "old.json.exr",
    "planes": [null, null, null, null, null, null, null, null]})";
  const formats::SweepAnalysis old = formats::ReadSweepAnalysis(dir.path() / "old.json");
  EXPECT_EQ(old.peak_time[10], 4.5f);
  EXPECT_EQ(old.peak_value[10], 0.5f);
  ASSERT_EQ(old.second_time.size(), old.peak_time.size());
  for (float t : old.second_time) EXPECT_TRUE(std::isnan(t));
  // A version 2 file must have all four channels.
  std::ofstream(dir.path() / "short.json") << R"({"format": "mesocap.sweep_analysis", "version": 2, "width": 16,
    "height": 8, "frame_count": 8, "image": "old.json.exr",
    "planes": [null, null, null, null, null, null, null, null]})";
  EXPECT_THROW(formats::ReadSweepAnalysis(dir.path() / "short.json"), core::FormatError);

  std::ofstream(dir.path() / "bad.json") << R"({"format": "mesocap.sweep_analysis", "version": 1, "width": 16,
    "height": 8, "frame_count": 2, "image": "bad.json.exr", "planes": [null]})";
  EXPECT_THROW(formats::ReadSweepAnalysis(dir.path() / "bad.json"), core::FormatError);
  std::ofstream(dir.path() / "bad2.json") << R"({"format": "mesocap.sweep_analysis", "version": 1, "width": 16,
    "height": 8, "frame_count": 1, "image": "x", "planes": [{"normal": [0, 0, 2], "offset_mm": 0}]})";
  EXPECT_THROW(formats::ReadSweepAnalysis(dir.path() / "bad2.json"), core::FormatError);

  // Strict: unknown members are errors, and a malformed plane is named
  // without the JSON library's own words.
  const auto error = [&](const std::string& name, const std::string& rest) {
    std::ofstream(dir.path() / name) << R"({"format": "mesocap.sweep_analysis", "version": 1, "width": 16,
      "height": 8, "frame_count": 1, "image": ")"
                                     << name << R"(.exr", )" << rest << "}";
    return testing::ErrorOf<core::FormatError>([&] { formats::ReadSweepAnalysis(dir.path() / name); });
  };
  EXPECT_EQ(error("extra.json", R"("planes": [null], "frames": 1)"),
            (dir.path() / "extra.json").string() +
                ": field 'frames': unknown member; expected only format, version, "
                "width, height, frame_count, image, planes");
  EXPECT_EQ(error("plane.json", R"("planes": [{"offset_mm": 0}])"),
            (dir.path() / "plane.json").string() + ": field 'planes[0].normal': missing");
  EXPECT_EQ(error("far.json", R"("planes": [{"normal": [0, 0, 1], "offset_mm": 1e300}])"),
            (dir.path() / "far.json").string() +
                ": field 'planes[0].offset_mm': expected a finite number in [-1e+06, 1e+06], got number 1e+300");
}

}  // namespace
}  // namespace mesocap::mdf
