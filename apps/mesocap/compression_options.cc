#include "apps/mesocap/compression_options.h"

#include "apps/mesocap/command.h"

namespace mesocap {

void AddCompressionOptions(CLI::App* sub, btf::BtfCompressionOptions* o) {
  // The CLI chooses the representation unless told; the library's default
  // (paper, rgb) is what a caller that sets nothing gets.
  o->layout.reset();
  o->color.reset();
  auto* rank = sub->add_option("--rank", o->rank,
                               "number of SVD terms, 1..100, of the representation --layout and --color give "
                               "(the paper's, paper and rgb, where they are auto)")
                   ->check(InRange(1, core::kMaxBtfRank));
  // A fixed rank does not choose: it is the paper's representation unless
  // the flags name another.
  sub->parse_complete_callback([o] {
    if (o->rank == 0) return;
    if (!o->layout) o->layout = core::BtfFactorLayout::kPaper;
    if (!o->color) o->color = core::BtfFactorColor::kRgb;
  });
  auto* max_bytes = sub->add_option("--max-bytes", o->max_bytes,
                                    "byte budget: the most accurate factors (float32) within this many bytes")
                        ->check(InRange(1, 1e15))
                        ->excludes(rank);
  sub->add_option("--max-error", o->max_relative_error,
                  "error budget: the smallest factors whose relative RMS error (of all RGB values) is at most this")
      ->check(InRange(1e-12, 1.0))
      ->capture_default_str()
      ->excludes(rank)
      ->excludes(max_bytes);
  sub->add_option_function<std::string>(
         "--layout",
         [o](const std::string& name) {
           if (name == "auto") {
             o->layout.reset();
           } else {
             o->layout = core::EnumFromString<core::BtfFactorLayout>(name);
           }
         },
         "matrix layout: paper (rows x, y, light; columns view), per_texel (rows x, y; columns view, light), "
         "clustered (per_texel within each cluster of texels: local PCA), per_view (rows x, y; columns light; "
         "one matrix per view) or auto (the smallest or most accurate for the budget)")
      ->check(CLI::IsMember({"auto", "paper", "per_texel", "clustered", "per_view"}))
      ->default_str("auto");
  sub->add_option("--clusters", o->clusters,
                  "clustered layout: the number of clusters, 1..1024 (default: 8, 32 and 128 tried)")
      ->check(InRange(1, core::kMaxBtfClusters));
  sub->add_option_function<std::string>(
         "--color",
         [o](const std::string& name) {
           if (name == "auto") {
             o->color.reset();
           } else {
             o->color = name == "rgb" ? core::BtfFactorColor::kRgb : core::BtfFactorColor::kYCbCr;
           }
         },
         "channels factored: rgb, ycbcr (luminance/chroma) or auto (the smaller or more accurate for the budget)")
      ->check(CLI::IsMember({"auto", "rgb", "ycbcr"}))
      ->default_str("auto");
  sub->add_option_function<std::string>(
         "--svd", [o](const std::string& name) { o->svd = core::ParseEnum<btf::BtfSvdMethod>(name, "SVD method"); },
         "exact (streamed QR), randomized (sketch and power iterations: for matrices over 2048 columns a side) "
         "or auto (randomized where both sides exceed 2048)")
      ->check(CLI::IsMember({"auto", "exact", "randomized"}))
      ->default_str("auto");
}

}  // namespace mesocap
