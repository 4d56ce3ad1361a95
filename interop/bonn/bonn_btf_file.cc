#include "interop/bonn/bonn_btf_file.h"
#include "core/angles.h"

#include <Eigen/LU>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image.h"
#include "formats/material_manifest.h"

namespace mesocap::bonn {
namespace fs = std::filesystem;
namespace {

// The files are little-endian (written by btflib's fwrite on x86); values are
// copied as bytes, so the host must be little-endian too.
static_assert(std::endian::native == std::endian::little, "the Bonn BTF reader assumes a little-endian host");

constexpr const char* kFmfSignature = "!FMF12FCER";
constexpr const char* kDfmfSignature = "!DFMF08FCR";
constexpr int kMetaStringBytes = 80;
constexpr std::uint32_t kMetaVersion = 4;
constexpr std::uint32_t kMaxNameBytes = 4096;
constexpr float kBonnHalfMax = 65504.0f;

// Signatures btflib accepts for the forms mesocap reads (ubo_btf_signatures.m),
// with whether an FMF header-version byte follows the common header.
struct Signature {
  const char* text;
  BonnBtfForm form;
  bool fmf_header_version;
};
constexpr Signature kSignatures[] = {
    {"!DFMF08FCR", BonnBtfForm::kDfmf, false},
    {"!FMF12FCER", BonnBtfForm::kFmf, true},
    {"!FMF06FCR", BonnBtfForm::kFmf, false},
    {"!FMF06FC", BonnBtfForm::kFmf, false},
};

std::string Num(double x) {
  std::ostringstream s;
  s.precision(9);
  s << x;
  return s.str();
}

// Sequential reads that name the field they were reading when the file
// ends early, and never allocate for more bytes than the file has left.
class ByteReader {
 public:
  explicit ByteReader(const fs::path& file) : file_(file) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) throw core::FormatError(file, "", "not a regular file");
    size_ = fs::file_size(file, ec);
    if (ec) throw core::FormatError(file, "", "cannot read its size: " + ec.message());
    in_.open(file, std::ios::binary);
    if (!in_) throw core::FormatError(file, "", "cannot open for reading");
  }

  const fs::path& file() const { return file_; }
  std::uint64_t offset() const { return offset_; }
  std::uint64_t remaining() const { return size_ - offset_; }

  void Need(std::uint64_t bytes, const std::string& field) const {
    if (bytes > remaining()) {
      throw core::FormatError(file_, field,
                              "truncated: needs " + std::to_string(bytes) + " bytes at offset " +
                                  std::to_string(offset_) + ", the file has " + std::to_string(remaining()) + " left");
    }
  }
  void Read(void* dst, std::uint64_t bytes, const std::string& field) {
    Need(bytes, field);
    in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(bytes));
    if (!in_) throw core::FormatError(file_, field, "read failed at offset " + std::to_string(offset_));
    offset_ += bytes;
  }
  void Skip(std::uint64_t bytes, const std::string& field) {
    Need(bytes, field);
    in_.seekg(static_cast<std::streamoff>(bytes), std::ios::cur);
    offset_ += bytes;
  }
  template <typename T>
  T Get(const std::string& field) {
    T v;
    Read(&v, sizeof v, field);
    return v;
  }
  std::string Chars(std::uint64_t bytes, const std::string& field) {
    Need(bytes, field);  // before allocating what the file claims
    std::string s(bytes, '\0');
    Read(s.data(), bytes, field);
    return s;
  }
  // A count in [lo, hi].
  int Count(const std::string& field, std::uint32_t lo, std::uint32_t hi) {
    const auto v = Get<std::uint32_t>(field);
    if (v < lo || v > hi) {
      throw core::FormatError(
          file_, field, "expected " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + std::to_string(v));
    }
    return static_cast<int>(v);
  }

 private:
  fs::path file_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;
};

// A fixed-length, NUL-padded string.
std::string Trimmed(std::string s) {
  const auto end = s.find('\0');
  if (end != std::string::npos) s.resize(end);
  return s;
}

BonnDirection ReadDirection(ByteReader& in, const std::string& field) {
  BonnDirection d;
  d.theta = in.Get<float>(field + ".theta");
  d.phi = in.Get<float>(field + ".phi");
  if (!std::isfinite(d.theta) || !(d.theta >= 0.0f) || !(d.theta < static_cast<float>(std::numbers::pi / 2))) {
    throw core::FormatError(in.file(), field + ".theta",
                            "expected a polar angle in [0, pi/2) rad (upper hemisphere), got " + Num(d.theta));
  }
  if (!std::isfinite(d.phi))
    throw core::FormatError(in.file(), field + ".phi", "expected a finite azimuth, got " + Num(d.phi));
  return d;
}

void ReadMeta(ByteReader& in, BonnBtfFile* btf) {
  const std::uint64_t start = in.offset();
  const auto size = in.Get<std::uint32_t>("meta.size");
  const auto version = in.Get<std::uint32_t>("meta.version");
  if (version < 1 || version > kMetaVersion) {
    throw core::FormatError(in.file(), "meta.version", "expected 1..4, got " + std::to_string(version));
  }
  btf->measurement_setup = Trimmed(in.Chars(kMetaStringBytes, "meta.measurement_setup"));
  btf->image_sensor = Trimmed(in.Chars(kMetaStringBytes, "meta.image_sensor"));
  btf->light_source = Trimmed(in.Chars(kMetaStringBytes, "meta.light_source"));
  btf->pixels_per_mm = in.Get<float>("meta.pixels_per_mm");
  if (!std::isfinite(btf->pixels_per_mm)) {
    throw core::FormatError(in.file(), "meta.pixels_per_mm",
                            "expected a finite number, got " + Num(btf->pixels_per_mm));
  }
  for (int c = 0; c < 3; ++c) btf->rgb_scale_factor[c] = in.Get<float>("meta.rgb_scale_factor");
  btf->cosine_flag = version > 1 ? in.Get<std::uint32_t>("meta.cosine_flag") != 0 : false;
  btf->xml.clear();
  if (version > 2) {
    const auto xml_size = in.Get<std::uint32_t>("meta.xml_size");
    btf->xml = in.Chars(xml_size, "meta.xml");
  }
  btf->channel_names = {"R", "G", "B"};
  if (version > 3) {
    const auto channels = in.Get<std::uint32_t>("meta.channel_count");
    if (channels != 3) {
      throw core::FormatError(
          in.file(), "meta.channel_count",
          "expected 3 colour channels (RGB), got " + std::to_string(channels) + " (spectral BTFs are not supported)");
    }
    btf->channel_names.clear();
    for (std::uint32_t c = 0; c < channels; ++c) {
      const std::string field = "meta.channel_names[" + std::to_string(c) + "]";
      const auto n = in.Get<std::uint32_t>(field + ".length");
      if (n > kMaxNameBytes) {
        throw core::FormatError(in.file(), field + ".length",
                                "expected at most " + std::to_string(kMaxNameBytes) + ", got " + std::to_string(n));
      }
      btf->channel_names.push_back(in.Chars(n, field));
    }
  }
  if (in.offset() - start != size) {
    throw core::FormatError(in.file(), "meta.size",
                            "says the meta-data block has " + std::to_string(size) + " bytes, its fields (version " +
                                std::to_string(version) + ") take " + std::to_string(in.offset() - start));
  }
}

void ReadDirections(ByteReader& in, BonnBtfFile* btf) {
  // Each view costs at least 12 bytes, each light 8: bound the counts by the
  // file before reserving anything.
  const int views = in.Count("views.count", 1, formats::kMaxDirections);
  in.Need(static_cast<std::uint64_t>(views) * 12, "views");
  btf->views.clear();
  btf->lights.clear();
  for (int v = 0; v < views; ++v) {
    const std::string field = "views[" + std::to_string(v) + "]";
    btf->views.push_back(ReadDirection(in, field));
    const int lights = in.Count(field + ".light_count", 1, formats::kMaxDirections);
    if (v > 0 && lights != btf->light_count()) {
      throw core::FormatError(in.file(), field + ".light_count",
                              "expected the same light count after every view (" + std::to_string(btf->light_count()) +
                                  "), got " + std::to_string(lights));
    }
    in.Need(static_cast<std::uint64_t>(lights) * 8, field + ".lights");
    for (int l = 0; l < lights; ++l) {
      const std::string light_field = field + ".lights[" + std::to_string(l) + "]";
      const BonnDirection d = ReadDirection(in, light_field);
      if (v == 0) {
        btf->lights.push_back(d);
      } else if (std::abs(d.theta - btf->lights[l].theta) > 1e-6f ||
                 std::abs(std::remainder(d.phi - btf->lights[l].phi, 2 * std::numbers::pi_v<float>)) > 1e-6f) {
        // mesocap's BTF is a tensor product: one light set for every view.
        throw core::FormatError(in.file(), light_field,
                                "expected the same light directions after every view; differs from views[0].lights[" +
                                    std::to_string(l) + "]");
      }
    }
  }
}

// Reads `count` scalars of `scalar` bytes into `dst` (floats), in chunks so
// that a half or double file never needs a second full-size buffer.
void ReadScalars(ByteReader& in, BonnScalar scalar, std::uint64_t count, float* dst, const std::string& field) {
  const int bytes = static_cast<int>(scalar);
  in.Need(count * bytes, field);
  if (scalar == BonnScalar::kFloat) {
    in.Read(dst, count * 4, field);
  } else {
    constexpr std::uint64_t kChunk = 1 << 16;
    std::vector<unsigned char> buffer(kChunk * bytes);
    for (std::uint64_t done = 0; done < count;) {
      const std::uint64_t n = std::min(kChunk, count - done);
      in.Read(buffer.data(), n * bytes, field);
      for (std::uint64_t i = 0; i < n; ++i) {
        if (scalar == BonnScalar::kHalf) {
          std::uint16_t bits;
          std::memcpy(&bits, buffer.data() + i * 2, 2);
          dst[done + i] = static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(bits));
        } else {
          double d;
          std::memcpy(&d, buffer.data() + i * 8, 8);
          dst[done + i] = static_cast<float>(d);
        }
      }
      done += n;
    }
  }
  for (std::uint64_t i = 0; i < count; ++i) {
    if (!std::isfinite(dst[i])) {
      throw core::FormatError(in.file(), field,
                              "value " + Num(dst[i]) + " at index " + std::to_string(i) + "; expected finite numbers");
    }
  }
}

BonnScalar ScalarOf(ByteReader& in, std::uint8_t size, const std::string& field) {
  if (size == 2) return BonnScalar::kHalf;
  if (size == 4) return BonnScalar::kFloat;
  if (size == 8) return BonnScalar::kDouble;
  throw core::FormatError(in.file(), field,
                          "expected 2 (half), 4 (float) or 8 (double) bytes, got " + std::to_string(size));
}

// Which way round a matrix of `rows` x `columns` lies; `channels` is 3 for
// FMF (the channel is part of the row index) and 1 for DFMF. When both fit
// (width x height = views x lights) it is direction rows: the database's
// orientation, which btflib's decoders test first.
BonnRowSpace RowSpaceOf(const ByteReader& in, const BonnBtfFile& btf, std::uint64_t rows, std::uint64_t columns,
                        int channels, const std::string& field) {
  const std::uint64_t texels = static_cast<std::uint64_t>(btf.width) * btf.height;
  const std::uint64_t directions = static_cast<std::uint64_t>(btf.view_count()) * btf.light_count();
  if (rows == channels * directions && columns == texels) return BonnRowSpace::kDirections;
  if (rows == channels * texels && columns == directions) return BonnRowSpace::kTexels;
  const std::string c = channels == 1 ? "" : std::to_string(channels) + " x ";
  throw core::FormatError(
      in.file(), field,
      "expected " + c + "lights x views = " + std::to_string(channels * directions) +
          " rows and width x height = " + std::to_string(texels) + " columns (the database's orientation), or " + c +
          "width x height = " + std::to_string(channels * texels) + " rows and lights x views = " +
          std::to_string(directions) + " columns; got " + std::to_string(rows) + " x " + std::to_string(columns));
}

BonnFactors ReadFactors(ByteReader& in, BonnScalar scalar, int rank, std::uint64_t rows, std::uint64_t columns,
                        const std::string& prefix) {
  const int bytes = static_cast<int>(scalar);
  const std::uint64_t total = (static_cast<std::uint64_t>(rank) * (1 + rows + columns)) * bytes;
  in.Need(total, prefix + "S, U, SxV");
  BonnFactors f;
  f.singular_values.resize(rank);
  f.u.resize(static_cast<Eigen::Index>(rows), rank);
  f.sxv.resize(static_cast<Eigen::Index>(columns), rank);
  ReadScalars(in, scalar, rank, f.singular_values.data(), prefix + "S");
  ReadScalars(in, scalar, rows * rank, f.u.data(), prefix + "U");
  ReadScalars(in, scalar, columns * rank, f.sxv.data(), prefix + "SxV");
  return f;
}

// --- writing ---

class ByteWriter {
 public:
  explicit ByteWriter(const fs::path& file) : file_(file), out_(file, std::ios::binary | std::ios::trunc) {
    if (!out_) throw core::Error(file.string() + ": cannot open for writing");
  }
  template <typename T>
  void Put(T v) {
    Write(&v, sizeof v);
  }
  void Write(const void* p, std::size_t bytes) {
    out_.write(static_cast<const char*>(p), static_cast<std::streamsize>(bytes));
    if (!out_) throw core::Error(file_.string() + ": write failed");
  }
  void Close() {
    out_.close();
    if (!out_) throw core::Error(file_.string() + ": write failed on close");
  }

 private:
  fs::path file_;
  std::ofstream out_;
};

void PutFixedString(ByteWriter& out, const std::string& s, const std::string& field) {
  if (s.size() > kMetaStringBytes) {
    throw core::Error("Bonn BTF " + field + " " + core::Quoted(s) + " is longer than " +
                      std::to_string(kMetaStringBytes) + " bytes");
  }
  std::string padded = s;
  padded.resize(kMetaStringBytes, '\0');
  out.Write(padded.data(), padded.size());
}

void PutDirection(ByteWriter& out, const BonnDirection& d) {
  out.Put<float>(d.theta);
  out.Put<float>(d.phi);
}

void PutCommonHeader(ByteWriter& out, const BonnBtfFile& btf, const char* signature) {
  out.Write(signature, std::strlen(signature));
  std::uint32_t meta_size =
      4 + 4 + 3 * kMetaStringBytes + 4 + 12 + 4 + 4 + static_cast<std::uint32_t>(btf.xml.size()) + 4;
  for (const auto& name : btf.channel_names) meta_size += 4 + static_cast<std::uint32_t>(name.size());
  out.Put<std::uint32_t>(meta_size);
  out.Put<std::uint32_t>(kMetaVersion);
  PutFixedString(out, btf.measurement_setup, "measurement_setup");
  PutFixedString(out, btf.image_sensor, "image_sensor");
  PutFixedString(out, btf.light_source, "light_source");
  out.Put<float>(btf.pixels_per_mm);
  for (int c = 0; c < 3; ++c) out.Put<float>(btf.rgb_scale_factor[c]);
  out.Put<std::uint32_t>(btf.cosine_flag ? 1 : 0);
  out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.xml.size()));
  out.Write(btf.xml.data(), btf.xml.size());
  out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.channel_names.size()));
  for (const auto& name : btf.channel_names) {
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(name.size()));
    out.Write(name.data(), name.size());
  }
  out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.views.size()));
  for (const auto& v : btf.views) {
    PutDirection(out, v);
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.lights.size()));
    for (const auto& l : btf.lights) PutDirection(out, l);
  }
  out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.width));
  out.Put<std::uint32_t>(static_cast<std::uint32_t>(btf.height));
  out.Put<std::uint32_t>(0);  // no rotations (both signatures end in 'R')
}

void PutScalars(ByteWriter& out, BonnScalar scalar, const float* values, std::size_t count, const std::string& what) {
  if (scalar == BonnScalar::kFloat) {
    out.Write(values, count * 4);
    return;
  }
  std::vector<std::uint16_t> bits(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (!(std::abs(values[i]) <= kBonnHalfMax)) {
      throw core::Error("Bonn BTF " + what + " value " + Num(values[i]) + " at index " + std::to_string(i) +
                        " does not fit a half float (|v| <= 65504); write float scalars instead");
    }
    bits[i] = Eigen::numext::bit_cast<std::uint16_t>(Eigen::half(values[i]));
  }
  out.Write(bits.data(), count * 2);
}

void PutFactors(ByteWriter& out, BonnScalar scalar, const BonnFactors& f, const std::string& what) {
  PutScalars(out, scalar, f.singular_values.data(), f.singular_values.size(), what + " S");
  PutScalars(out, scalar, f.u.data(), f.u.size(), what + " U");
  PutScalars(out, scalar, f.sxv.data(), f.sxv.size(), what + " SxV");
}

void CheckForWriting(const BonnBtfFile& btf) {
  if (btf.views.empty() || btf.lights.empty()) throw core::Error("Bonn BTF: no view or light directions to write");
  if (btf.width <= 0 || btf.height <= 0) throw core::Error("Bonn BTF: the texture size must be positive");
  if (btf.channel_names.size() != 3) throw core::Error("Bonn BTF: expected 3 channel names");
  const std::size_t expected = btf.form == BonnBtfForm::kFmf ? 1 : 3;
  if (btf.factors.size() != expected) {
    throw core::Error("Bonn BTF: expected " + std::to_string(expected) + " factor sets, got " +
                      std::to_string(btf.factors.size()));
  }
  const int channels = btf.form == BonnBtfForm::kFmf ? 3 : 1;
  const Eigen::Index texels = static_cast<Eigen::Index>(btf.width) * btf.height;
  const Eigen::Index directions = static_cast<Eigen::Index>(btf.view_count()) * btf.light_count();
  const Eigen::Index rows = channels * (btf.row_space == BonnRowSpace::kTexels ? texels : directions);
  const Eigen::Index columns = btf.row_space == BonnRowSpace::kTexels ? directions : texels;
  for (const auto& f : btf.factors) {
    if (f.rank() < 1 || f.u.rows() != rows || f.sxv.rows() != columns || f.sxv.cols() != f.rank() ||
        f.singular_values.size() != f.rank()) {
      throw core::Error("Bonn BTF: factor sizes " + std::to_string(f.u.rows()) + "x" + std::to_string(f.u.cols()) +
                        " and " + std::to_string(f.sxv.rows()) + "x" + std::to_string(f.sxv.cols()) + " do not match " +
                        std::to_string(rows) + " rows and " + std::to_string(columns) + " columns");
    }
  }
}

}  // namespace

core::SphericalAngles AnglesFromBonn(const BonnDirection& d) {
  core::SphericalAngles a;
  a.theta = d.theta;
  double phi = std::fmod(static_cast<double>(d.phi), core::kTwoPi);
  if (phi < 0.0) phi += core::kTwoPi;
  if (phi >= core::kTwoPi) phi = 0.0;
  a.phi = a.theta == 0.0 ? 0.0 : phi;
  return a;
}

BonnDirection BonnFromAngles(const core::SphericalAngles& a) {
  // btflib's cart2sph2 gives phi = atan2(y, x) in (-pi, pi].
  return {static_cast<float>(a.theta), static_cast<float>(std::remainder(a.phi, 2.0 * std::numbers::pi))};
}

BonnBtfFile ReadBonnBtfFile(const fs::path& file) {
  ByteReader in(file);
  // The longest matching signature wins, as in btflib (identify_signature.m).
  const std::string head = in.Chars(std::min<std::uint64_t>(10, in.remaining()), "signature");
  const Signature* match = nullptr;
  for (const auto& s : kSignatures) {
    const std::size_t n = std::strlen(s.text);
    if (head.compare(0, n, s.text) == 0 && (!match || n > std::strlen(match->text))) match = &s;
  }
  if (!match) {
    std::string shown;
    for (unsigned char c : head) shown += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
    throw core::FormatError(
        file, "signature",
        "expected \"!FMF12FCER\", \"!FMF06FCR\", \"!FMF06FC\" or \"!DFMF08FCR\", got \"" + shown + "\"");
  }
  BonnBtfFile btf;
  btf.form = match->form;
  btf.signature = match->text;
  // Back to just after the signature (the 10 bytes read may be more).
  ByteReader body(file);
  body.Skip(btf.signature.size(), "signature");

  ReadMeta(body, &btf);
  ReadDirections(body, &btf);
  btf.width = body.Count("width", 1, core::kMaxImageSide);
  btf.height = body.Count("height", 1, core::kMaxImageSide);
  if (btf.signature.back() == 'R') {
    const auto rotations = body.Get<std::uint32_t>("rotations.count");
    body.Skip(static_cast<std::uint64_t>(rotations) * 36, "rotations");
  }

  if (btf.form == BonnBtfForm::kFmf) {
    int header_version = 0;
    if (match->fmf_header_version) {
      header_version = body.Get<std::uint8_t>("fmf.header_version");
      if (header_version > 2) {
        throw core::FormatError(file, "fmf.header_version", "expected 0..2, got " + std::to_string(header_version));
      }
    }
    if (header_version >= 1) btf.dynamic_range_reduction = body.Get<std::uint32_t>("fmf.dynamic_range_reduction");
    if (header_version >= 2) {
      const auto w = body.Get<std::uint32_t>("fmf.height_map_size");
      const auto h = body.Get<std::uint32_t>("fmf.height_map_size");
      body.Skip(static_cast<std::uint64_t>(w) * h * 2, "fmf.height_map");
    }
    const auto rank_file = body.Get<std::uint32_t>("components");
    const BonnScalar scalar = ScalarOf(body, body.Get<std::uint8_t>("scalar_size"), "scalar_size");
    const auto rank = body.Get<std::uint32_t>("components (repeated)");
    if (rank != rank_file || rank < 1) {
      throw core::FormatError(file, "components (repeated)",
                              "expected a positive count equal to the first (" + std::to_string(rank_file) + "), got " +
                                  std::to_string(rank));
    }
    const auto rows = body.Get<std::uint32_t>("rows");
    const auto columns = body.Get<std::uint32_t>("columns");
    btf.row_space = RowSpaceOf(body, btf, rows, columns, 3, "rows");
    btf.scalar = scalar;
    btf.factors.push_back(ReadFactors(body, scalar, static_cast<int>(rank), rows, columns, ""));
  } else {
    const auto max_rank = body.Get<std::uint32_t>("components");
    btf.color_model = body.Get<std::int32_t>("color_model");
    for (int c = 0; c < 3; ++c) btf.color_mean[c] = body.Get<float>("color_mean");
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) btf.color_matrix(r, c) = body.Get<float>("color_transformation_matrix");
    if (!btf.color_mean.allFinite() || !btf.color_matrix.allFinite()) {
      throw core::FormatError(file, "color_transformation_matrix", "expected finite colour mean and matrix");
    }
    for (int c = 0; c < 3; ++c) {
      const std::string prefix = "channels[" + std::to_string(c) + "].";
      const BonnScalar scalar = ScalarOf(body, body.Get<std::uint8_t>(prefix + "scalar_size"), prefix + "scalar_size");
      const auto rank = body.Get<std::uint32_t>(prefix + "components");
      if (rank < 1 || rank > max_rank) {
        throw core::FormatError(
            file, prefix + "components",
            "expected 1.." + std::to_string(max_rank) + " (the header's largest count), got " + std::to_string(rank));
      }
      const auto rows = body.Get<std::uint32_t>(prefix + "rows");
      const auto columns = body.Get<std::uint32_t>(prefix + "columns");
      const BonnRowSpace space = RowSpaceOf(body, btf, rows, columns, 1, prefix + "rows");
      if (c > 0 && space != btf.row_space) {
        throw core::FormatError(file, prefix + "rows", "expected the same matrix orientation as channels[0]");
      }
      btf.row_space = space;
      if (c == 0) btf.scalar = scalar;
      btf.factors.push_back(ReadFactors(body, scalar, static_cast<int>(rank), rows, columns, prefix));
    }
  }
  if (body.remaining() != 0) {
    throw core::FormatError(file, "size",
                            std::to_string(body.remaining()) + " bytes after the last factor matrix; expected none " +
                                "(inconsistent counts in the header?)");
  }
  return btf;
}

bool IsBonnBtfFile(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(file, ec))) return false;
  std::ifstream in(file, std::ios::binary);
  char start[16] = {};
  in.read(start, sizeof start);
  const std::string_view head(start, static_cast<std::size_t>(in.gcount()));
  for (const Signature& s : kSignatures) {
    if (head.substr(0, std::strlen(s.text)) == s.text) return true;
  }
  return false;
}

void WriteBonnBtfFile(const fs::path& file, const BonnBtfFile& btf, BonnScalar scalar) {
  if (scalar == BonnScalar::kDouble) throw core::Error("Bonn BTF: mesocap writes half or float factors, not double");
  CheckForWriting(btf);
  // With as many texels as direction pairs the counts cannot tell the
  // orientation, and readers (btflib, btf.hh, ReadBonnBtfFile) take U's
  // rows as directions: write it so. A DFMF matrix is transposed by
  // swapping its factors; an FMF's is not (its channel index belongs to the
  // texel side).
  if (btf.row_space == BonnRowSpace::kTexels &&
      static_cast<long long>(btf.width) * btf.height == static_cast<long long>(btf.view_count()) * btf.light_count()) {
    if (btf.form == BonnBtfForm::kFmf) {
      throw core::Error("Bonn FMF: width x height equals views x lights (" + std::to_string(btf.width * btf.height) +
                        "), so a reader would take the texel rows for direction rows; write a DFMF instead");
    }
    BonnBtfFile swapped = btf;
    swapped.row_space = BonnRowSpace::kDirections;
    for (auto& f : swapped.factors) std::swap(f.u, f.sxv);
    WriteBonnBtfFile(file, swapped, scalar);
    return;
  }
  core::AtomicFile target(file);
  ByteWriter out(target.temp_path());
  const auto byte = static_cast<std::uint8_t>(scalar);
  if (btf.form == BonnBtfForm::kFmf) {
    PutCommonHeader(out, btf, kFmfSignature);
    const BonnFactors& f = btf.factors[0];
    out.Put<std::uint8_t>(2);  // header version: drr method and (empty) height map follow
    out.Put<std::uint32_t>(btf.dynamic_range_reduction);
    out.Put<std::uint32_t>(0);
    out.Put<std::uint32_t>(0);
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.rank()));
    out.Put<std::uint8_t>(byte);
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.rank()));
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.u.rows()));
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.sxv.rows()));
    PutFactors(out, scalar, f, "FMF");
  } else {
    PutCommonHeader(out, btf, kDfmfSignature);
    int max_rank = 0;
    for (const auto& f : btf.factors) max_rank = std::max(max_rank, f.rank());
    out.Put<std::uint32_t>(static_cast<std::uint32_t>(max_rank));
    out.Put<std::int32_t>(btf.color_model);
    for (int c = 0; c < 3; ++c) out.Put<float>(btf.color_mean[c]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out.Put<float>(btf.color_matrix(r, c));
    for (std::size_t c = 0; c < btf.factors.size(); ++c) {
      const BonnFactors& f = btf.factors[c];
      out.Put<std::uint8_t>(byte);
      out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.rank()));
      out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.u.rows()));
      out.Put<std::uint32_t>(static_cast<std::uint32_t>(f.sxv.rows()));
      PutFactors(out, scalar, f, "DFMF channel " + std::to_string(c));
    }
  }
  out.Close();
  target.Commit();
}

const char* BonnColorModelName(int model) {
  switch (model) {
    case 0:
      return "RGB";
    case 1:
      return "YUV";
    case 2:
      return "LAB";
    case 3:
      return "PCA";
    case 4:
      return "YCoCg";
    case 5:
      return "SPECTRAL";
    case 6:
      return "SPECTRAL_LINEAR";
    case 9:
      return "Ylog_UV";
    case 10:
      return "Ylog_Ulog_Vlog";
    case 11:
      return "Ylog_UdivY_VdivY";
    case 12:
      return "log RGB";
    default:
      return "unknown";
  }
}

BonnColorTransform BonnToRgb(const BonnBtfFile& btf) {
  BonnColorTransform t;
  if (btf.form == BonnBtfForm::kFmf) return t;
  switch (btf.color_model) {
    case kBonnColorRgb:
      return t;
    case kBonnColorYuv:
      // The YUV -> RGB matrix of btflib's undecorrelate.m (BT.601 analogue YUV).
      t.to_rgb << 1, 0, 1.13983, 1, -0.39465, -0.5806, 1, 2.03211, 0;
      return t;
    case kBonnColorPca:
      // btflib: rgb_row = f_row * M + mean, so rgb = M^T f + mean.
      t.to_rgb = btf.color_matrix.cast<double>().transpose();
      t.offset = btf.color_mean.cast<double>();
      return t;
    case kBonnColorYcocg:
      t.to_rgb << 1, 1, -1, 1, 0, 1, 1, -1, -1;
      return t;
    default:
      throw core::Error("DFMF colour model " + std::to_string(btf.color_model) + " (" +
                        BonnColorModelName(btf.color_model) +
                        ") is not supported: mesocap reads the linear models 0 RGB, 1 YUV, 3 PCA and 4 YCoCg");
  }
}

}  // namespace mesocap::bonn
