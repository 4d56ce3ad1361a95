// The simulated cameras against the truth they are built from: projection
// (OpenCV model), the laser plane, the sensor's noise statistics,
// determinism, and a whole `mesocap simulate` session on the tiny rig.
#include "sim/camera_renderer.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>

#include "core/angles.h"
#include "core/error.h"
#include "core/image_io.h"
#include "formats/capture_journal.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/frame_sequence.h"
#include "sim/camera_sensor.h"
#include "sim/laser_sweep_renderer.h"
#include "sim/shipped_rigs.h"
#include "tests/common/error_of.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = core::kRadiansPerDegree;

Eigen::Vector3d SampleToWorld(const Eigen::Vector3d& p, double turntable_rad) {
  return Eigen::AngleAxisd(turntable_rad, Eigen::Vector3d::UnitZ()) * p;
}

TEST(CameraModelTest, UndistortInvertsTheForwardModelToAThousandthOfAPixel) {
  for (const auto& name : ShippedRigNames()) {
    const auto rig = LoadRig(name);
    const auto scene = MakeBuiltinScene("flat");
    const CameraRenderer renderer(*scene, rig);
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const formats::CameraCalibration& cam = renderer.calibration().cameras[c];
      double worst = 0.0;
      for (int j = 0; j <= 8; ++j) {
        for (int i = 0; i <= 8; ++i) {
          // Past the image corners by a pixel, where distortion is strongest.
          const Eigen::Vector2d pixel(-1.0 + (cam.width + 1.0) * i / 8, -1.0 + (cam.height + 1.0) * j / 8);
          const Eigen::Vector3d ray = renderer.PixelRay(static_cast<int>(c), pixel.x(), pixel.y());
          const Eigen::Vector2d back = ProjectToPixel(cam, renderer.CameraCentre(static_cast<int>(c)) + 100.0 * ray);
          worst = std::max(worst, (back - pixel).norm());
        }
      }
      EXPECT_LT(worst, 1e-3) << name << " camera " << c;
    }
  }
}

// Where the row (or column) `line` of the image crosses the projected
// segment a-b (sample frame points on z = 0), by bisection on the segment.
std::optional<double> PredictedCrossing(const formats::CameraCalibration& cam, const Eigen::Vector3d& a,
                                        const Eigen::Vector3d& b, double turntable_rad, bool along_rows, double line) {
  const int axis = along_rows ? 1 : 0;
  auto project = [&](double s) { return ProjectToPixel(cam, SampleToWorld(a + s * (b - a), turntable_rad)); };
  double lo = 0.25, hi = 0.75;  // away from the corners, where the other edge is near
  double flo = project(lo)[axis] - line, fhi = project(hi)[axis] - line;
  if (flo * fhi > 0) return std::nullopt;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    const double fmid = project(mid)[axis] - line;
    if (fmid * flo <= 0) {
      hi = mid;
    } else {
      lo = mid;
      flo = fmid;
    }
  }
  return project(0.5 * (lo + hi))[1 - axis];
}

// (a) Projection: the flat sample (albedo 0.5) in its pocket of the
// turntable (albedo 0.3), both at z = 0 under one lamp, so the image is a
// step in brightness exactly along the projected sample edges. The measured
// edge (half-way crossing between the two levels, linear between pixel
// centres) lies within 0.5 px of the OpenCV projection of the true edge.
TEST(CameraRendererTest, SampleEdgesAppearWhereTheTrueCalibrationProjectsThem) {
  const auto rig = LoadRig("tiny");
  const auto scene = MakeBuiltinScene("flat");
  const CameraRenderer renderer(*scene, rig);
  const double tt = 30 * kDeg;  // edges oblique to the pixel grid
  const double h = rig.sample_size_mm / 2;
  const Eigen::Vector3d corners[4] = {{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}};
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    const formats::CameraCalibration& cam = renderer.calibration().cameras[c];
    const core::Image image = renderer.RenderLamps(renderer.TraceSample(c, tt), 0.0, {true, false});
    int checked = 0;
    double worst = 0.0;
    for (int e = 0; e < 4; ++e) {
      const Eigen::Vector3d& a = corners[e];
      const Eigen::Vector3d& b = corners[(e + 1) % 4];
      const Eigen::Vector2d pa = ProjectToPixel(cam, SampleToWorld(a, tt));
      const Eigen::Vector2d pb = ProjectToPixel(cam, SampleToWorld(b, tt));
      ASSERT_TRUE(pa.x() > 0 && pa.x() < cam.width - 1 && pa.y() > 0 && pa.y() < cam.height - 1);
      // Scan across the edge: along rows when the edge is steep in the image.
      const bool along_rows = std::abs(pb.y() - pa.y()) > std::abs(pb.x() - pa.x());
      const int n_lines = along_rows ? cam.height : cam.width;
      for (int line = 0; line < n_lines; ++line) {
        const auto predicted = PredictedCrossing(cam, a, b, tt, along_rows, line);
        if (!predicted) continue;
        auto value = [&](int k) { return along_rows ? image.at(k, line, 0) : image.at(line, k, 0); };
        const int k0 = static_cast<int>(std::lround(*predicted));
        const double lo_level = value(k0 - 2), hi_level = value(k0 + 2);
        ASSERT_GT(std::abs(hi_level - lo_level), 0.03) << "no contrast across the edge";
        const double half = 0.5 * (lo_level + hi_level);
        std::optional<double> measured;
        for (int k = k0 - 2; k < k0 + 2; ++k) {
          const double v0 = value(k) - half, v1 = value(k + 1) - half;
          if (v0 * v1 <= 0 && v0 != v1) measured = k + v0 / (v0 - v1);
        }
        ASSERT_TRUE(measured) << "camera " << c << " edge " << e << " line " << line;
        worst = std::max(worst, std::abs(*measured - *predicted));
        ++checked;
      }
    }
    EXPECT_GT(checked, 30) << "camera " << c;
    EXPECT_LT(worst, 0.5) << "camera " << c;
  }
}

// Sub-pixel peak of three samples of a Gaussian profile (exact for a
// Gaussian): the offset from the middle one, in samples.
double GaussianPeakOffset(double a, double b, double c) {
  const double la = std::log(a), lb = std::log(b), lc = std::log(c);
  return 0.5 * (la - lc) / (la - 2 * lb + lc);
}

struct StripeCheck {
  int peaks = 0;
  double worst_mm = 0.0;
};

// Scans the frame across the stripe (columns: the stripe runs roughly along
// the image rows for these cameras and laser azimuths), finds each column's
// peak pixels, refines them to sub-pixel and back-projects the refined
// position onto the true surface; returns the worst distance of those points
// from the true laser plane. Peaks whose three pixels do not all see one
// face, fully lit by the laser (`face` gives the height of the face a pixel
// sees, or nullopt), are skipped: a depth step or a shadow edge inside the
// profile.
template <typename BackProject, typename Face>
StripeCheck CheckStripe(const core::Image& frame, const LaserPlane& plane, const BackProject& back_project,
                        const Face& face) {
  StripeCheck out;
  float max_value = 0.0f;
  for (std::size_t i = 0; i < frame.size(); ++i) max_value = std::max(max_value, frame.data()[i]);
  for (int x = 0; x < frame.width(); ++x) {
    for (int y = 1; y + 1 < frame.height(); ++y) {
      const double a = frame.at(x, y - 1), b = frame.at(x, y), c = frame.at(x, y + 1);
      if (!(b > 0.25 * max_value && b >= a && b > c && a > 0 && c > 0)) continue;
      const auto f = face(x, y);
      if (!f || face(x, y - 1) != f || face(x, y + 1) != f) continue;
      const auto p = back_project(x, y + GaussianPeakOffset(a, b, c));
      EXPECT_TRUE(p);
      if (!p) continue;
      out.worst_mm = std::max(out.worst_mm, std::abs(plane.normal.dot(*p - plane.source)));
      ++out.peaks;
    }
  }
  return out;
}

// (b) Laser: every peak of the stripe, refined to sub-pixel and
// back-projected onto the true surface, lies on the true laser plane: within
// 0.01 mm with one ray per pixel (the refinement is then exact up to the
// curvature of the projection), 0.03 mm with the default 3 x 3 box-filtered
// rays (sigma 0.3 mm, ~0.4 mm pixels). Box scene (faces at z = 0 and -1 and
// the turntable), every laser location, sweep positions across the sample;
// and the calibration plates (Sec. 3.2) at tilt 0.
TEST(CameraRendererTest, StripePeaksLieOnTheTrueLaserPlane) {
  const auto rig = LoadRig("tiny");
  const auto scene = MakeBuiltinScene("box");
  for (const int side : {1, 3}) {
    const double tolerance_mm = side == 1 ? 0.01 : 0.03;
    const CameraRenderer renderer(*scene, rig, {side});
    const double tt = 20 * kDeg;
    for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
      const CameraView view = renderer.TraceSample(c, tt);
      auto on_sample = [&](double u, double v) -> std::optional<Eigen::Vector3d> {
        const ViewSample s = renderer.FirstHit(c, tt, u, v);
        if (s.surface == ViewSample::Surface::kNothing) return std::nullopt;
        return s.Point();
      };
      for (const auto& loc : rig.laser.locations) {
        const LaserSweepRenderer sweep(renderer, view, loc.mount, loc.arc_angle_rad);
        const Eigen::Vector3d source = renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0).source;
        // The height of the face all of the pixel's rays see, all lit.
        auto face = [&](int x, int y) -> std::optional<double> {
          const std::size_t first = (static_cast<std::size_t>(y) * view.width + x) * view.samples_per_pixel;
          const ViewSample s0 = view.Sample(first);
          for (int k = 0; k < view.samples_per_pixel; ++k) {
            const ViewSample s = view.Sample(first + k);
            if (s.surface == ViewSample::Surface::kNothing || s.Point().z() != s0.Point().z() ||
                !renderer.Lit(view, s, source)) {
              return std::nullopt;
            }
          }
          return s0.Point().z();
        };
        for (const double offset : {-4.0, 0.0, 2.5}) {
          const double tilt = calibration::LaserTiltForOffset(rig.laser, loc.mount, offset);
          const StripeCheck check = CheckStripe(
              sweep.Frame(tilt), renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, tilt), on_sample, face);
          EXPECT_GT(check.peaks, 40) << "camera " << c << " offset " << offset;
          EXPECT_LT(check.worst_mm, tolerance_mm) << "side " << side << " camera " << c << " offset " << offset;
        }
      }
      for (const double height : rig.laser.calibration_heights_mm) {
        const CameraView plate = renderer.TracePlate(c, height);
        auto on_plate = [&](double u, double v) -> std::optional<Eigen::Vector3d> {
          const Eigen::Vector3d o = renderer.CameraCentre(c), d = renderer.PixelRay(c, u, v);
          return o + ((height - o.z()) / d.z()) * d;
        };
        for (const auto& loc : rig.laser.locations) {
          const StripeCheck check =
              CheckStripe(LaserSweepRenderer(renderer, plate, loc.mount, loc.arc_angle_rad).Frame(0),
                          renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0), on_plate,
                          [](int, int) { return std::optional<double>(0.0); });
          EXPECT_GT(check.peaks, 20) << "camera " << c << " plate " << height;
          EXPECT_LT(check.worst_mm, tolerance_mm) << "side " << side << " camera " << c << " plate " << height;
        }
      }
    }
  }
}

// A sweep frame visits only the samples whose tilt range holds the tilt
// (camera_renderer.h); it must equal the sum over every lit sample of the
// pixel, sum_k w_k exp(-d_k^2 / (2 sigma^2)) / n with d_k the sample's
// distance from the true plane (cut off at 8 sigma), at tilts across the
// sweep and anywhere on the circle (the plane then meets the sample
// elsewhere, or wraps past +-pi).
// The variance of a sample's distance from a plane (normal `normal`) over
// its footprint, 1 / side of a pixel on each axis (camera_renderer.h), here
// by central differences of pinhole rays met with the sample's tangent
// plane; NaN where that plane is within kMinFootprintCosine of edge-on.
double FootprintVarianceByDifferences(const formats::CameraCalibration& c, const ViewSample& s,
                                      const Eigen::Vector3d& normal, int side) {
  const Eigen::Vector3d centre = c.pose.transform.translation;
  const Eigen::Matrix3d& rotation = c.pose.transform.rotation;
  const Eigen::Vector3d local = rotation.transpose() * (s.Point() - centre);
  const formats::Intrinsics& k = c.intrinsics;
  const double u = k.fx * local.x() / local.z() + k.cx, v = k.fy * local.y() / local.z() + k.cy;
  if (std::abs(s.Normal().dot((s.Point() - centre).normalized())) < kMinFootprintCosine) return std::nan("");
  auto hit = [&](double du, double dv) {
    const Eigen::Vector3d dir = rotation * Eigen::Vector3d((u + du - k.cx) / k.fx, (v + dv - k.cy) / k.fy, 1.0);
    return Eigen::Vector3d(centre + s.Normal().dot(s.Point() - centre) / s.Normal().dot(dir) * dir);
  };
  const double h = 1e-3;
  const double g_u = normal.dot(hit(h, 0) - hit(-h, 0)) / (2 * h) / side;
  const double g_v = normal.dot(hit(0, h) - hit(0, -h)) / (2 * h) / side;
  return (g_u * g_u + g_v * g_v) / 12.0;
}

TEST(CameraRendererTest, SweepFramesEqualTheSumOverEveryLitSample) {
  const auto rig = LoadRig("tiny");
  const auto scene = MakeBuiltinScene("weave");
  const CameraRenderer renderer(*scene, rig, {2});
  const int camera = 1;
  const CameraView view = renderer.TraceSample(camera, 0.4);
  const auto& loc = rig.laser.locations[2];
  const LaserSweepRenderer sweep(renderer, view, loc.mount, loc.arc_angle_rad);
  const Eigen::Vector3d source = renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0).source;
  const Eigen::Vector3d centre = renderer.CameraCentre(camera);
  const double gain =
      rig.cameras[camera].exposure_us * 1e-6 * kSignalPerRadianceSecond * renderer.LaserPeakIrradiance();
  const double sigma = rig.laser.stripe_sigma_mm;
  const formats::CameraCalibration& calibration = renderer.calibration().cameras.at(camera);
  const Eigen::Vector3d plane_at_zero = renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0).normal;
  std::vector<double> tilts;
  for (const double offset : {-7.0, -2.0, 0.0, 0.3, 4.0, 7.0})
    tilts.push_back(calibration::LaserTiltForOffset(rig.laser, loc.mount, offset));
  for (const double t : {-3.14159, -1.2, 0.9, 3.1415926}) tilts.push_back(t);
  int lit_pixels = 0, edge_on_pixels = 0, widened_pixels = 0;
  for (const double tilt : tilts) {
    const LaserPlane plane = renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad, tilt);
    const core::Image frame = sweep.Frame(tilt);
    const core::Image single = LaserSweepRenderer::SingleFrame(renderer, view, loc.mount, loc.arc_angle_rad, tilt);
    for (int y = 0; y < view.height; ++y) {
      for (int x = 0; x < view.width; ++x) {
        double expected = 0.0;
        bool edge_on = false, widened = false;
        for (int k = 0; k < view.samples_per_pixel; ++k) {
          const ViewSample s = view.Sample((static_cast<std::size_t>(y) * view.width + x) * view.samples_per_pixel + k);
          if (s.surface == ViewSample::Surface::kNothing) continue;
          const Eigen::Vector3d l = (source - s.Point()).normalized();
          const double n_dot_l = s.Normal().dot(l);
          if (n_dot_l <= 0.0 || !renderer.Lit(view, s, source)) continue;
          const double footprint = FootprintVarianceByDifferences(calibration, s, plane_at_zero, 2);
          edge_on |= std::isnan(footprint);
          const double wide = std::sqrt(sigma * sigma + footprint);
          widened |= wide > 1.1 * sigma;
          const double d = plane.normal.dot(s.Point() - plane.source);
          if (std::abs(d) >= 8.0 * wide) continue;
          const Eigen::Vector3f f = s.reflectance.Evaluate(s.Normal(), l, (centre - s.Point()).normalized());
          expected += (f.sum() / 3.0) * n_dot_l * gain * (sigma / wide) * std::exp(-d * d / (2 * wide * wide)) /
                      view.samples_per_pixel;
        }
        if (edge_on) {  // the footprint is bounded there (kMinFootprintCosine)
          ++edge_on_pixels;
          continue;
        }
        lit_pixels += expected > 1e-3 ? 1 : 0;
        widened_pixels += expected > 1e-3 && widened ? 1 : 0;
        ASSERT_NEAR(frame.at(x, y), expected, 1e-6 + 1e-4 * expected) << "tilt " << tilt << " pixel " << x << ", " << y;
        ASSERT_NEAR(single.at(x, y), expected, 1e-6 + 1e-4 * expected)
            << "tilt " << tilt << " pixel " << x << ", " << y;
      }
    }
  }
  EXPECT_GT(lit_pixels, 500);
  EXPECT_GT(widened_pixels, 50) << "the tiny rig's 2 x 2 samples are wider than the stripe on slanted threads";
  EXPECT_LT(edge_on_pixels, lit_pixels / 10);
}

// A laser plate's frame without the sweep (as CameraRenderer renders the
// plate steps) is the sweep's frame but for the order in which a pixel adds
// its samples: float rounding, 1e-6 of the value.
TEST(CameraRendererTest, APlateFrameWithoutTheSweepIsTheSweepsFrame) {
  const auto rig = LoadRig("small");
  const auto scene = MakeBuiltinScene("weave");
  const CameraRenderer renderer(*scene, rig, {3});
  const CameraView plate = renderer.TracePlate(2, 4.0);
  const auto& loc = rig.laser.locations[1];
  const LaserSweepRenderer sweep(renderer, plate, loc.mount, loc.arc_angle_rad);
  int lit = 0;
  for (const double offset : {-5.0, 0.0, 2.5}) {
    const double tilt = calibration::LaserTiltForOffset(rig.laser, loc.mount, offset);
    const core::Image frame = sweep.Frame(tilt);
    const core::Image single = LaserSweepRenderer::SingleFrame(renderer, plate, loc.mount, loc.arc_angle_rad, tilt);
    for (std::size_t i = 0; i < frame.size(); ++i) {
      lit += frame.data()[i] > 1e-3f ? 1 : 0;
      ASSERT_NEAR(single.data()[i], frame.data()[i], 1e-6f * (1.0f + frame.data()[i]))
          << "tilt " << tilt << " pixel " << i;
    }
  }
  EXPECT_GT(lit, 300);
}

// A sweep kept for tilts within a quarter turn (as CameraRenderer keeps
// every sweep) renders those tilts as the whole turn's does and refuses a
// tilt beyond.
TEST(CameraRendererTest, SweepWithinAQuarterTurnMatchesTheWholeTurn) {
  const auto rig = LoadRig("tiny");
  const auto scene = MakeBuiltinScene("weave");
  const CameraRenderer renderer(*scene, rig, {2});
  const CameraView view = renderer.TraceSample(0, 0.4);
  const auto& loc = rig.laser.locations[2];
  const LaserSweepRenderer whole(renderer, view, loc.mount, loc.arc_angle_rad);
  const LaserSweepRenderer quarter(renderer, view, loc.mount, loc.arc_angle_rad, kMaxSweptTiltRad);
  double lit = 0.0;
  for (const double offset : {-7.0, -2.0, 0.0, 0.3, 4.0, 7.0}) {
    const double tilt = calibration::LaserTiltForOffset(rig.laser, loc.mount, offset);
    const core::Image a = whole.Frame(tilt), b = quarter.Frame(tilt);
    for (std::size_t i = 0; i < a.size(); ++i) {
      // Equal up to the order in which a pixel's samples add up.
      ASSERT_NEAR(b.data()[i], a.data()[i], 1e-6 * (1.0 + a.data()[i])) << "tilt " << tilt << " value " << i;
      lit += a.data()[i];
    }
  }
  EXPECT_GT(lit, 1.0);
  EXPECT_NE(testing::ErrorOf([&] { quarter.Frame(2.0); }).find("beyond the sweep's"), std::string::npos);
  EXPECT_NO_THROW(whole.Frame(2.0));
}

// A stripe much narrower than a pixel's footprint (the paper rig's lowest
// camera, 5.6 degrees above the plate: a pixel spans ~1.1 mm of it, the
// stripe's sigma is 0.15 mm) must not alias at 1 ray per pixel: each
// column's brightest value then matches the 5 x 5-ray rendering of the same
// frame (the footprint's Gaussian has the box's energy but a 1.4x higher
// peak at this width: within 50 %), where point samples between the pixel
// centres would miss the stripe in most columns.
TEST(CameraRendererTest, StripeNarrowerThanAPixelFootprintDoesNotAlias) {
  auto rig = LoadRig("paper");
  const int camera = 7;
  // The middle 256 x 256 pixels of its 1024 x 768 (same focal length, so
  // the same footprints), which hold the stripe on the 10 mm plate.
  auto& cut = rig.cameras[camera];
  cut.principal_point_px -= Eigen::Vector2d((cut.width - 256) / 2.0, (cut.height - 256) / 2.0);
  cut.width = cut.height = 256;
  const auto scene = MakeBuiltinScene("flat");
  const auto& loc = rig.laser.locations[12];  // mount 2, arc 0: the stripe runs across the camera's view
  std::vector<float> column_peaks[2];
  for (const int side : {1, 5}) {
    const CameraRenderer renderer(*scene, rig, {side});
    const CameraView plate = renderer.TracePlate(camera, 10.0);
    const core::Image frame = LaserSweepRenderer(renderer, plate, loc.mount, loc.arc_angle_rad).Frame(0.0);
    std::vector<float>& peaks = column_peaks[side == 1 ? 0 : 1];
    for (int x = 0; x < frame.width(); ++x) {
      float peak = 0.0f;
      for (int y = 0; y < frame.height(); ++y) peak = std::max(peak, frame.at(x, y));
      peaks.push_back(peak);
    }
  }
  int compared = 0, matched = 0;
  for (std::size_t x = 0; x < column_peaks[0].size(); ++x) {
    const float fine = column_peaks[1][x];
    if (fine < 0.01f) continue;
    ++compared;
    const float ratio = column_peaks[0][x] / fine;
    matched += ratio > 0.5f && ratio < 1.5f ? 1 : 0;
  }
  ASSERT_GT(compared, 200);
  EXPECT_EQ(matched, compared);
}

// One-bounce interreflection of the stripe: a plane cannot light itself, so
// the flat sample's sweep is unchanged to the bit; in the weave's concave
// crossings it adds light, less than the direct light it comes from (a
// bounce off albedo <= 0.6 surfaces loses at least 40 %), and some pixels
// see a ghost: light in frames where the stripe is far from their point.
TEST(CameraRendererTest, InterreflectionAddsGhostLightOnlyWhereSurfacesSeeEachOther) {
  const auto rig = LoadRig("tiny");
  const auto& loc = rig.laser.locations[1];
  std::vector<double> tilts;
  for (int f = 0; f < 64; ++f) {
    tilts.push_back(calibration::LaserTiltForOffset(rig.laser, loc.mount, -6.0 + 12.0 * f / 63));
  }
  auto sweep = [&](const MesostructureScene& scene, int rays) {
    CameraRendererOptions options;
    options.samples_per_pixel_side = 1;
    options.interreflection_rays_per_pixel = rays;
    const CameraRenderer renderer(scene, rig, options);
    const CameraView view = renderer.TraceSample(0, 0.3);
    const LaserSweepRenderer laser(renderer, view, loc.mount, loc.arc_angle_rad);
    std::vector<core::Image> frames;
    for (double t : tilts) frames.push_back(laser.Frame(t));
    return frames;
  };
  const auto flat = MakeBuiltinScene("flat");
  const auto flat_direct = sweep(*flat, 0), flat_bounced = sweep(*flat, 32);
  for (std::size_t f = 0; f < tilts.size(); ++f) {
    EXPECT_TRUE(
        std::equal(flat_direct[f].data(), flat_direct[f].data() + flat_direct[f].size(), flat_bounced[f].data()))
        << "frame " << f;
  }

  const auto weave = MakeBuiltinScene("weave");
  const auto direct = sweep(*weave, 0), bounced = sweep(*weave, 32);
  double direct_sum = 0.0, added_sum = 0.0;
  int ghost_pixels = 0;
  const int pixels = direct[0].width() * direct[0].height();
  for (int p = 0; p < pixels; ++p) {
    float peak = 0.0f;
    for (const core::Image& frame : direct) peak = std::max(peak, frame.data()[p]);
    bool ghost = false;
    for (std::size_t f = 0; f < tilts.size(); ++f) {
      const float d = direct[f].data()[p], b = bounced[f].data()[p];
      EXPECT_GE(b, d - 1e-7f) << "light can only be added";
      direct_sum += d;
      added_sum += b - d;
      // Light where the direct stripe is absent from this pixel.
      ghost = ghost || (peak > 0.05f && d < 1e-6f && b - d > 2e-3f);
    }
    ghost_pixels += ghost ? 1 : 0;
  }
  EXPECT_GT(added_sum, 0.01 * direct_sum);  // measured 3.3 %
  EXPECT_LT(added_sum, 0.3 * direct_sum);
  EXPECT_GT(ghost_pixels, 20);  // measured 86 of 12288
}

// The laser planes follow the rig's conventions: tilt 0 aims at the origin
// and LaserTiltForOffset(o) puts the stripe on the turntable plane at o
// from the origin, away from the laser (calibration/nominal_geometry.h).
TEST(CameraRendererTest, LaserPlanesFollowTheRigConventions) {
  const auto rig = LoadRig("small");
  const auto scene = MakeBuiltinScene("flat");
  const CameraRenderer renderer(*scene, rig);
  for (const auto& loc : rig.laser.locations) {
    const Eigen::Vector3d away(-std::cos(loc.arc_angle_rad), -std::sin(loc.arc_angle_rad), 0.0);
    for (const double offset : {-13.0, 0.0, 5.0, 13.0}) {
      const LaserPlane plane = renderer.LaserPlaneAt(loc.mount, loc.arc_angle_rad,
                                                     calibration::LaserTiltForOffset(rig.laser, loc.mount, offset));
      EXPECT_NEAR(plane.normal.dot(offset * away - plane.source), 0.0, 1e-9) << offset;
      EXPECT_NEAR((plane.source - calibration::LaserSource(rig.laser, loc)).norm(), 0.0, 1e-9);
    }
  }
}

TEST(CameraRendererTest, RaysThroughHolesMeetTheBackingBoard) {
  // The sponge's open squares go right through its 1.2 mm slab; the small
  // rig holds it over a grey board 8 mm down.
  const auto rig = LoadRig("small");
  ASSERT_TRUE(rig.backing.present());
  const auto scene = MakeBuiltinScene("sponge");
  const CameraRenderer renderer(*scene, rig);
  auto no_board = rig;
  no_board.backing = {};
  const CameraRenderer black(*scene, no_board);
  const int camera = 0;  // 11.25 degrees from the normal
  const auto& c = rig.cameras[camera];
  int through = 0, lit = 0;
  const Eigen::Vector3d lamp(0.0, 0.0, 500.0);  // straight above: down through the holes
  const CameraView view = renderer.TraceSample(camera, 0.0);
  for (int y = c.height / 4; y < 3 * c.height / 4; y += 3) {
    for (int x = c.width / 4; x < 3 * c.width / 4; x += 3) {
      const ViewSample s = renderer.FirstHit(camera, 0.0, x, y);
      if (s.surface != ViewSample::Surface::kBacking) {
        EXPECT_EQ(black.FirstHit(camera, 0.0, x, y).surface, s.surface);
        continue;
      }
      ++through;
      EXPECT_NEAR(s.Point().z(), -rig.backing.depth_mm, 1e-9);
      EXPECT_LE(std::max(std::abs(s.Point().x()), std::abs(s.Point().y())), 0.5 * rig.sample_size_mm);
      EXPECT_FLOAT_EQ(s.reflectance.diffuse_albedo.x(), static_cast<float>(rig.backing.albedo));
      // The same ray finds no mesostructure above the board, and without a
      // board it sees black.
      EXPECT_EQ(black.FirstHit(camera, 0.0, x, y).surface, ViewSample::Surface::kNothing);
      // Light reaches the board only through a hole above it: the lattice's
      // open squares are (1.2 mm)^2 of every 2 mm x 2 mm.
      if (renderer.Lit(view, s, lamp)) ++lit;
    }
  }
  EXPECT_GT(through, 100);
  EXPECT_GT(lit, 0);
  EXPECT_LT(lit, through);
  // A board inside (or too close to) the slab is refused, naming the field.
  auto shallow = rig;
  shallow.backing.depth_mm = scene->d_max_mm() + 0.5;
  try {
    CameraRenderer(*scene, shallow);
    ADD_FAILURE() << "a backing 0.5 mm below the sponge was accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample.backing.depth_mm"), std::string::npos) << e.what();
  }
}

formats::CameraDescription TestCamera(double read_noise) {
  formats::CameraDescription camera;
  camera.bit_depth = 12;
  camera.full_well_electrons = 20000;
  camera.read_noise_electrons = read_noise;
  return camera;
}

// (c) Sensor: without noise only quantization (<= half a code) and
// saturation; with noise the variance of a flat field is shot + read noise
// (+ the 1/12 code^2 of quantization) within 10 %.
TEST(CameraSensorTest, QuantizesToHalfACodeAndSaturates) {
  const auto camera = TestCamera(5.0);
  core::Image signal(97, 31, 3);
  for (std::size_t i = 0; i < signal.size(); ++i) signal.data()[i] = static_cast<float>(1.3 * i / signal.size());
  std::mt19937_64 rng(7);
  const core::Image out = ApplySensor(signal, camera, rng, false);
  const double max_code = MaxCode(camera);
  EXPECT_EQ(max_code, 4095.0);
  for (std::size_t i = 0; i < signal.size(); ++i) {
    const double s = signal.data()[i], v = out.data()[i];
    const double code = v * max_code;
    EXPECT_NEAR(code, std::round(code), 1e-3) << "not a code";
    if (s >= 1.0) {
      EXPECT_EQ(v, 1.0f) << "saturation";
    } else {
      EXPECT_LE(std::abs(v - s), 0.5 / max_code + 1e-7) << i;
    }
  }
}

TEST(CameraSensorTest, FlatFieldVarianceIsShotPlusReadNoise) {
  for (const auto& [level, read_noise] : {std::pair{0.3, 5.0}, std::pair{0.005, 50.0}, std::pair{0.8, 8.0}}) {
    const auto camera = TestCamera(read_noise);
    const core::Image signal(256, 256, 1, static_cast<float>(level));
    std::mt19937_64 rng(11);
    const core::Image out = ApplySensor(signal, camera, rng, true);
    const double codes_per_electron = MaxCode(camera) / camera.full_well_electrons;
    double sum = 0, sum2 = 0;
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double code = out.data()[i] * MaxCode(camera);
      sum += code;
      sum2 += code * code;
    }
    const double n = static_cast<double>(out.size());
    const double mean = sum / n;
    const double variance = sum2 / n - mean * mean;
    const double electrons = level * camera.full_well_electrons;
    const double expected =
        (electrons + read_noise * read_noise) * codes_per_electron * codes_per_electron + 1.0 / 12.0;
    EXPECT_NEAR(variance, expected, 0.1 * expected) << "level " << level << " read noise " << read_noise;
    // Within a quarter code: clamping at code 0 lifts the mean of the
    // faintest level (read noise 10 codes around a mean of 20) by ~0.07.
    EXPECT_NEAR(mean, electrons * codes_per_electron, 0.25) << "level " << level;
  }
}

// A dark pixel (zero signal: most of a sweep frame) reads the read noise
// alone, rounded and clamped at code 0. Its codes are drawn by a table
// (camera_sensor.cc); their histogram must match the model's probabilities,
// Phi((k + 1/2) / sigma) - Phi((k - 1/2) / sigma), within 5 standard errors,
// and match the normal-draw path a faint signal (1e-9 of full scale) takes.
TEST(CameraSensorTest, DarkPixelsReadTheRoundedClampedReadNoise) {
  for (const double read_noise : {0.0, 8.0, 50.0}) {
    const auto camera = TestCamera(read_noise);
    const double sigma = read_noise * MaxCode(camera) / camera.full_well_electrons;  // in codes
    auto histogram = [&](float level) {
      const core::Image signal(512, 512, 1, level);
      std::mt19937_64 rng(13);
      const core::Image out = ApplySensor(signal, camera, rng, true);
      std::vector<double> h(80, 0.0);
      for (std::size_t i = 0; i < out.size(); ++i) {
        const double code = out.data()[i] * MaxCode(camera);
        EXPECT_NEAR(code, std::round(code), 1e-3);
        h[std::min<std::size_t>(79, static_cast<std::size_t>(std::lround(code)))] += 1.0 / out.size();
      }
      return h;
    };
    const std::vector<double> dark = histogram(0.0f), faint = histogram(1e-9f);
    const double n = 512.0 * 512.0;
    for (int k = 0; k < 80; ++k) {
      auto phi = [&](double x) {
        return sigma > 0 ? 0.5 * std::erfc(-x / (sigma * std::numbers::sqrt2)) : (x > 0 ? 1.0 : 0.0);
      };
      const double p = k == 0 ? phi(0.5) : phi(k + 0.5) - phi(k - 0.5);
      const double tolerance = 5.0 * std::sqrt(p * (1 - p) / n) + 1e-9;
      EXPECT_NEAR(dark[k], p, tolerance) << "read noise " << read_noise << " code " << k;
      EXPECT_NEAR(faint[k], p, tolerance) << "read noise " << read_noise << " code " << k;
    }
  }
}

// Shot noise is Poisson, whichever way it is drawn (inversion below a mean
// of 12 electrons, std::poisson_distribution above): a camera with one
// electron per code and no read noise reads the electron count itself, and
// the histogram matches the Poisson probabilities within 5 standard errors.
TEST(CameraSensorTest, ShotNoiseIsPoisson) {
  formats::CameraDescription camera = TestCamera(0.0);
  camera.full_well_electrons = MaxCode(camera);  // one electron a code
  for (const double mean : {0.02, 3.0, 11.5, 30.0}) {
    const core::Image signal(512, 256, 1, static_cast<float>(mean / camera.full_well_electrons));
    std::mt19937_64 rng(17);
    const core::Image out = ApplySensor(signal, camera, rng, true);
    std::vector<double> histogram(100, 0.0);
    for (std::size_t i = 0; i < out.size(); ++i) {
      histogram[std::min<long>(99, std::lround(out.data()[i] * MaxCode(camera)))] += 1.0 / out.size();
    }
    double p = std::exp(-mean);
    for (int k = 0; k < 99; ++k) {
      if (k > 0) p *= mean / k;
      EXPECT_NEAR(histogram[k], p, 5.0 * std::sqrt(p * (1 - p) / out.size()) + 1e-9) << "mean " << mean << " k " << k;
    }
  }
}

// (d) Determinism: the same seed gives the same noise, another seed other
// noise; rendering is deterministic whatever the threads do.
TEST(CameraSensorTest, NoiseIsDeterministicForASeed) {
  const auto camera = TestCamera(5.0);
  const core::Image signal(64, 32, 3, 0.4f);
  auto noisy = [&](std::uint64_t seed, std::uint64_t frame) {
    std::mt19937_64 rng = ImageNoiseGenerator(seed, {3, 1, frame});
    return ApplySensor(signal, camera, rng, true);
  };
  const core::Image a = noisy(42, 0), b = noisy(42, 0), c = noisy(43, 0), d = noisy(42, 1);
  EXPECT_TRUE(std::equal(a.data(), a.data() + a.size(), b.data()));
  EXPECT_FALSE(std::equal(a.data(), a.data() + a.size(), c.data()));
  EXPECT_FALSE(std::equal(a.data(), a.data() + a.size(), d.data()));
}

TEST(CameraRendererTest, RenderingIsDeterministic) {
  const auto rig = LoadRig("tiny");
  const auto scene = MakeBuiltinScene("weave");
  CameraRenderer renderer(*scene, rig);
  SimulatedRigState state;
  state.turntable_rad = 1.0;
  state.light_arc_rad = 0.5;
  state.lamps_on = {true, true};
  state.laser_on = true;
  state.laser_mount = 1;
  state.laser_tilt_rad = 0.002;
  const core::Image a = renderer.Render(state, 1, 3), b = renderer.Render(state, 1, 3);
  ASSERT_EQ(a.channels(), 3);
  EXPECT_TRUE(std::equal(a.data(), a.data() + a.size(), b.data()));
  // A mono readout is the mean of the RGB signal (lamps and laser on here;
  // the laser alone takes a shortcut, checked below).
  const core::Image mono = renderer.Render(state, 1, 1);
  ASSERT_EQ(mono.channels(), 1);
  const core::Image mean = core::ChannelMean(a);
  for (std::size_t i = 0; i < mono.size(); ++i) ASSERT_NEAR(mono.data()[i], mean.data()[i], 1e-6f) << i;
  state.lamps_on = {false, false};
  const core::Image laser_rgb = renderer.Render(state, 1, 3), laser_mono = renderer.Render(state, 1, 1);
  double lit = 0;
  for (std::size_t p = 0; p < laser_mono.size(); ++p) {
    ASSERT_EQ(laser_mono.data()[p], laser_rgb.data()[3 * p]) << p;  // the stripe is grey
    lit += laser_mono.data()[p];
  }
  EXPECT_GT(lit, 0.0);
  EXPECT_THROW(renderer.Render(state, 1, 2), core::Error);
  float max_value = 0;
  for (std::size_t i = 0; i < a.size(); ++i) max_value = std::max(max_value, a.data()[i]);
  EXPECT_GT(max_value, 0.2f) << "signal scale: typical signals at 0.2-0.8 of full scale";
}

// The signal scale: lamps and laser land in the sensor's range on the
// shipped rigs (kSignalPerRadianceSecond).
TEST(CameraRendererTest, SignalsLandInTheSensorsRange) {
  for (const auto& name : ShippedRigNames()) {
    const auto rig = LoadRig(name);
    const auto scene = MakeBuiltinScene("flat");
    const CameraRenderer renderer(*scene, rig, {1});
    // Analytic: the flat sample (albedo 0.5) at the origin.
    const Eigen::Vector3d lamp = calibration::LampPosition(rig.lamps, 0, 0.0);
    const double gain = rig.cameras[0].exposure_us * 1e-6 * kSignalPerRadianceSecond;
    const double lamp_signal =
        0.5 / std::numbers::pi * rig.lamps.intensity.mean() / lamp.squaredNorm() * lamp.normalized().z() * gain;
    const Eigen::Vector3d source = calibration::LaserSource(rig.laser, rig.laser.locations[0]);
    const double laser_signal =
        0.5 / std::numbers::pi * renderer.LaserPeakIrradiance() * source.normalized().z() * gain;
    EXPECT_GT(lamp_signal, 0.1) << name;
    EXPECT_LT(lamp_signal, 0.8) << name;
    EXPECT_GT(laser_signal, 0.2) << name;
    EXPECT_LT(laser_signal, 0.95) << name;
  }
}

// (e) A whole tiny-rig session of the flat scene: the manifest and journal
// read back, every planned step is journaled, every file is there with the
// journaled size, and the files hold what the plan says.
TEST(SimulateCommandTest, TinySessionIsCompleteAndReadable) {
  testing::TemporaryDirectory dir;
  const fs::path session = dir / "session";
  const std::string cmd = std::string(MESOCAP_BINARY) +
                          " -q simulate --scene flat --rig tiny --seed 3 --samples-per-pixel-side 1 --out " +
                          session.string() + " 2>" + (dir / "err").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const formats::SessionManifest manifest = formats::ReadSessionManifest(session);
  const formats::JournalContents journal =
      formats::ReadCaptureJournal(session / formats::kSessionJournalName, &manifest);
  const auto rig = LoadRig("tiny");
  EXPECT_EQ(manifest.rig, rig.json);
  ASSERT_TRUE(manifest.calibration);
  EXPECT_TRUE(fs::exists(session / *manifest.calibration));
  const std::size_t expected_steps =
      rig.turntable.angles_rad.size() *
          (rig.light_arc.angles_rad.size() * rig.lamps.elevations_rad.size() + rig.laser.locations.size()) +
      2 * rig.laser.locations.size();
  ASSERT_EQ(manifest.plan.size(), expected_steps);
  ASSERT_EQ(journal.records.size(), expected_steps);
  EXPECT_EQ(journal.dropped_bytes, 0u);
  std::set<std::string> done;
  for (const auto& r : journal.records) {
    done.insert(r.step);
    EXPECT_EQ(r.files.size(), rig.cameras.size());
    for (const auto& f : r.files) EXPECT_EQ(fs::file_size(session / f.path), f.bytes) << f.path;
  }
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const formats::PlannedStep& step = manifest.plan[s];
    EXPECT_TRUE(done.count(step.id)) << step.id;
    const formats::CaptureStep typed = formats::ReadCaptureStep(step, s, rig, session / formats::kSessionManifestName);
    for (const formats::CameraFile& f : formats::Files(typed)) {
      const fs::path file = session / f.path;
      ASSERT_TRUE(fs::exists(file)) << file;
      if (step.kind == formats::StepKind::kLaserSweep) {
        const auto header = formats::ReadFrameSequenceHeader(file);
        EXPECT_EQ(header.frame_count, rig.laser.frames_per_sweep);
        EXPECT_EQ(std::get<formats::LaserSweepStep>(typed).tilts_rad.size(),
                  static_cast<std::size_t>(rig.laser.frames_per_sweep));
        EXPECT_EQ(header.width, 128);
        EXPECT_EQ(header.encoding, core::PixelEncoding::kUInt16);
      } else {
        const auto header = core::ReadImageHeader(file);
        EXPECT_EQ(header.encoding, core::PixelEncoding::kUInt16);
        EXPECT_EQ(header.channels, step.kind == formats::StepKind::kBtfImage ? 3 : 1);
      }
    }
  }
  // A second run refuses the existing session; --resume finds nothing to do.
  EXPECT_NE(std::system(cmd.c_str()), 0);
  ASSERT_EQ(std::system((cmd + " --resume").c_str()), 0);
  EXPECT_EQ(formats::ReadCaptureJournal(session / formats::kSessionJournalName, &manifest).records.size(),
            expected_steps);
}

}  // namespace
}  // namespace mesocap::sim
