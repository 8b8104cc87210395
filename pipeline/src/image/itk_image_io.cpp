// The ITK side of image IO (see itk_image_io.hpp). The header is read first through the ImageIO
// factory so that the dimension, pixel type and spacing are checked before any voxel is allocated;
// the voxels are then read as float by ImageFileReader (ITK converts any scalar component type).
// No Eigen header may be included here (ITK bundles its own, older Eigen).
#include "image/itk_image_io.hpp"

#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOBase.h>
#include <itkImageIOFactory.h>
#include <itkMetaImageIO.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <vim/pipeline/common/input_error.hpp>

namespace vim::pipeline::itk_io {

namespace fs = std::filesystem;

namespace {

constexpr double max_voxels = 2.0e9;  // refuse headers that declare absurd sizes before allocating

// ITK messages span several lines ("file:line: ... Description: ..."); keep the description only.
std::string one_line(const std::string& text) {
  std::string s = text;
  const auto d = s.find("Description:");
  if (d != std::string::npos) s = s.substr(d + 12);
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  const auto b = s.find_first_not_of(' ');
  const auto e = s.find_last_not_of(' ');
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

// MetaIO reports some errors only on std::cerr/std::cout (a truncated voxel block is read without an
// exception). While alive, captures both streams so the messages can be checked and folded into one
// error line instead of reaching the user's terminal.
class StreamCapture {
 public:
  StreamCapture() : old_err_(std::cerr.rdbuf(err_.rdbuf())), old_out_(std::cout.rdbuf(out_.rdbuf())) {}
  ~StreamCapture() {
    std::cerr.rdbuf(old_err_);
    std::cout.rdbuf(old_out_);
  }
  StreamCapture(const StreamCapture&) = delete;
  StreamCapture& operator=(const StreamCapture&) = delete;
  std::string text() const { return err_.str() + out_.str(); }

 private:
  std::ostringstream err_, out_;
  std::streambuf* old_err_;
  std::streambuf* old_out_;
};

const char* supported_formats() {
  return "MetaImage (.mha/.mhd), NRRD (.nrrd/.nhdr) or NIfTI (.nii/.nii.gz)";
}

void quiet_itk() {
  static const bool done = [] {
    itk::Object::GlobalWarningDisplayOff();  // warnings would break the one-line error contract
    return true;
  }();
  (void)done;
}

// MetaIO (ITK 5.2) mishandles some ElementDataFile values when it reads the voxels: a value with
// '%' is used as a printf format for numbered slice files (fuzz_image_header: std::length_error
// escaping from ITK; a format-string hazard), and a missing external data file leaks its stream.
// Checked after the header is parsed (MetaIO's own parse) and before any voxel is read: LOCAL, or
// one existing, readable data file.
// MetaIO's spellings of "the voxel data follow the header in this file".
bool is_local_data(const std::string& value) {
  return value == "LOCAL" || value == "Local" || value == "local";
}

// The file holding a MetaImage's voxel data: the header's own file, or ElementDataFile relative to the
// header's folder.
fs::path metaimage_data_path(const std::string& path, const std::string& value) {
  if (is_local_data(value)) return fs::path(path);
  const fs::path data(value);
  return data.is_relative() ? fs::path(path).parent_path() / data : data;
}

void check_metaimage_data_file(const std::string& path, const std::string& value) {
  if (is_local_data(value)) return;
  if (value.find('%') != std::string::npos || value.compare(0, 4, "LIST") == 0)
    throw InputError(
        path + ": ElementDataFile = '" + one_line(value) +
        "' (a list or numbered pattern of slice files) is not supported; use LOCAL or one data file");
  const fs::path data = metaimage_data_path(path, value);
  std::error_code ec;
  if (value.empty() || !fs::is_regular_file(data, ec) || ::access(data.c_str(), R_OK) != 0)
    throw InputError(path + ": ElementDataFile = '" + one_line(value) + "': data file " + data.string() +
                     " does not exist or is not readable");
}

// MetaIO keeps header state between the reads ITK makes of one file (ReadImageInformation, again in
// ImageFileReader, again in Read): a header that repeats NDims/DimSize or gives fewer DimSize values
// than NDims can yield a voxel count on the last read larger than the buffer ITK allocated
// (fuzz_image_header: heap-buffer-overflow in MetaImage::M_ReadElementData). Such headers are
// rejected before ITK parses them, as is an NDims outside 1..10. Lines are "Key = value" (or "Key: value") as
// MetaIO reads them, up to ElementDataFile, after which the voxel data starts.
void check_metaimage_header_text(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".mha" && ext != ".mhd") return;
  std::ifstream in(path, std::ios::binary);
  const auto trim = [](std::string t) {
    t = t.substr(0, t.find('\0'));  // MetaIO compares keys as C strings
    const auto b = t.find_first_not_of(" \t\r\v\f");
    const auto e = t.find_last_not_of(" \t\r\v\f");
    return b == std::string::npos ? std::string() : t.substr(b, e - b + 1);
  };
  std::string line;
  std::size_t scanned = 0;
  int ndims_seen = 0, dimsize_seen = 0, line_no = 0;
  long ndims = -1, dimsize_count = -1;
  while (scanned < (1u << 20) && std::getline(in, line)) {
    scanned += line.size() + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;  // blank line
    const auto sep = line.find_first_of("=:");
    // MetaIO copies an unknown key into a fixed 255-byte field name (strcpy: "buffer overflow
    // detected" abort in MET_InitReadField, fuzz_image_header).
    if (trim(line.substr(0, sep)).size() > 250)
      throw InputError(path + ": corrupt MetaImage header: a header key is longer than 250 characters");
    // Every header line must be "Key = value": MetaIO reads a malformed line differently on each of
    // ITK's header passes (a key runs on to the next '=' across lines), so the size it reads the
    // voxels with can differ from the checked one (fuzz_image_header: heap-buffer-overflow in
    // MetaImage::M_ReadElementData, regress_mha_malformed_line_overflow). Keys are letters, digits
    // and '_'; values have no control characters (tabs are fine; bytes >= 0x80 are, for UTF-8 names).
    const std::string where =
        path + ": not a readable image (corrupt MetaImage header): line " + std::to_string(line_no) + " ";
    if (sep == std::string::npos) throw InputError(where + "is not 'Key = value'");
    const std::string key = trim(line.substr(0, sep));
    if (key.empty() || line.substr(0, sep).find('\0') != std::string::npos ||
        !std::all_of(key.begin(), key.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }))
      throw InputError(where + "has a key that is not letters, digits and '_'");
    const std::string value = line.substr(sep + 1);
    if (std::any_of(value.begin(), value.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return (u < 0x20 && c != '\t') || u == 0x7f;
        }))
      throw InputError(where + "(" + key + ") has a control character in its value");
    // MetaIO strcpy's string values into fixed 255-byte fields too (fuzz_image_header: a long
    // ObjectType value, regress_mha_long_value_strcpy).
    if (trim(value).size() > 250)
      throw InputError(where + "(" + key + ") has a value longer than 250 characters");
    if (key == "NDims") {
      ++ndims_seen;
      ndims = std::strtol(value.c_str(), nullptr, 10);
    } else if (key == "DimSize") {
      ++dimsize_seen;
      std::istringstream v(value.substr(0, value.find('\0')));
      double x = 0.0;
      dimsize_count = 0;
      while (v >> x) ++dimsize_count;
    } else if (key == "ElementDataFile") {
      break;
    }
  }
  // MetaIO loops forever reading the per-axis fields of a header with a negative NDims (fuzz_image_header
  // timeout); it supports at most 10 axes.
  if (ndims_seen == 1 && (ndims < 1 || ndims > 10))
    throw InputError(path + ": corrupt MetaImage header: NDims = " + std::to_string(ndims) +
                     "; expected 2 or 3");
  if (ndims_seen > 1 || dimsize_seen > 1)
    throw InputError(path + ": corrupt MetaImage header: " + (ndims_seen > 1 ? "NDims" : "DimSize") +
                     " is given more than once");
  if (ndims_seen == 1 && dimsize_seen == 1 && dimsize_count != ndims)
    throw InputError(path + ": corrupt MetaImage header: DimSize has " + std::to_string(dimsize_count) +
                     " values but NDims = " + std::to_string(ndims));
}

// NRRD headers are checked line by line before teem parses them: after the NRRD000X magic line,
// every line up to the blank line that ends the header is a comment ('#'), "field: description"
// or "key:=value", with no control characters (tabs are fine), at most 500 characters long and a
// field/key of at most 250 characters (fuzz_image_header: long lines smashed teem's stack,
// regress_nrrd_garbage_line_stack_smash, regress_nrrd_long_line_biff_smash).
void check_nrrd_header_text(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".nrrd" && ext != ".nhdr") return;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  int line_no = 0;
  std::size_t scanned = 0;
  while (scanned < (1u << 20) && std::getline(in, line)) {
    scanned += line.size() + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;  // end of the header; attached data follow
    const std::string where =
        path + ": not a readable image (corrupt NRRD header): line " + std::to_string(line_no) + " ";
    if (line_no == 1) {
      if (line.rfind("NRRD000", 0) != 0) throw InputError(where + "is not the NRRD000X magic");
      continue;
    }
    if (std::any_of(line.begin(), line.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return (u < 0x20 && c != '\t') || u == 0x7f;
        }))
      throw InputError(where + "has a control character");
    // teem copies an offending line into a fixed-size error message on the stack (biffAddf: a
    // stack smash on a 400-character line, regress_nrrd_long_line_biff_smash).
    if (line.size() > 500) throw InputError(where + "is longer than 500 characters");
    if (line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos || colon == 0)
      throw InputError(where + "is not 'field: description' or 'key:=value'");
    if (colon > 250) throw InputError(where + "has a field name longer than 250 characters");
  }
}

// Opens the header and checks everything that can be checked without reading voxels.
itk::ImageIOBase::Pointer open_header(const std::string& path) {
  quiet_itk();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": file does not exist");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a directory, not an image file");
  if (::access(path.c_str(), R_OK) != 0)
    throw InputError(path + ": file is not readable (permission denied)");
  if (fs::file_size(path, ec) == 0) throw InputError(path + ": file is empty (0 bytes)");
  check_metaimage_header_text(path);
  check_nrrd_header_text(path);
  check_nifti_header_numbers(path);

  itk::ImageIOBase::Pointer io =
      itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::ImageIOFactory::IOFileModeEnum::ReadMode);
  if (!io)
    throw InputError(path + ": not a readable image (unknown format or corrupt header); expected " +
                     supported_formats());
  // Only the documented input formats. Other registered IOs (PNGImageIO, registered for the
  // figures) are not input formats, and ITK 5.2's PNG reader aborts the process on a corrupt PNG
  // (libpng png_error without a jump buffer; found by fuzz_image_header with PNG bytes in a .mha).
  const std::string io_name = io->GetNameOfClass();
  if (io_name != "MetaImageIO" && io_name != "NrrdImageIO" && io_name != "NiftiImageIO")
    throw InputError(path + ": " + (io_name == "PNGImageIO" ? std::string("PNG") : io_name) +
                     " files are not supported as input images; expected " + supported_formats());
  io->SetFileName(path);
  {
    StreamCapture capture;
    try {
      io->ReadImageInformation();
    } catch (const itk::ExceptionObject& e) {
      const std::string detail = one_line(capture.text());
      throw InputError(path + ": cannot read the image header: " + (detail.empty() ? "" : detail + "; ") +
                       one_line(e.GetDescription()));
    } catch (const std::exception& e) {  // std::length_error, std::bad_alloc, ... from inside ITK
      throw InputError(path + ": cannot read the image header: " + one_line(e.what()));
    }
  }
  if (auto* meta = dynamic_cast<itk::MetaImageIO*>(io.GetPointer()))
    check_metaimage_data_file(path, meta->GetMetaImagePointer()->ElementDataFileName());
  const unsigned d = io->GetNumberOfDimensions();
  if (d != 2 && d != 3)
    throw InputError(path + ": image has " + std::to_string(d) + " dimensions; expected 2 or 3");
  if (io->GetNumberOfComponents() != 1)
    throw InputError(path + ": pixels have " + std::to_string(io->GetNumberOfComponents()) +
                     " components (vector/RGB/complex image); expected a scalar image (1 component)");
  if (io->GetComponentType() == itk::IOComponentEnum::UNKNOWNCOMPONENTTYPE)
    throw InputError(path +
                     ": unknown voxel component type; expected an integer or floating-point scalar type");
  double n = 1.0;
  for (unsigned a = 0; a < d; ++a) {
    if (io->GetDimensions(a) == 0)
      throw InputError(path + ": image is empty (size 0 along axis " + std::to_string(a) + ")");
    n *= static_cast<double>(io->GetDimensions(a));
    const double s = io->GetSpacing(a);
    if (!(s > 0.0) || !std::isfinite(s)) {
      std::ostringstream m;
      m << path << ": spacing along axis " << a << " is " << s << "; spacing must be positive and finite";
      throw InputError(m.str());
    }
    if (!std::isfinite(io->GetOrigin(a)))
      throw InputError(path + ": origin along axis " + std::to_string(a) + " is not finite");
  }
  if (n > max_voxels) {
    std::ostringstream m;
    m << path << ": header declares " << n << " voxels, more than the supported " << max_voxels;
    throw InputError(m.str());
  }
  // A file too short for the declared voxels is truncated: say so before ITK allocates the declared
  // size (fuzz_image_header: a 200-byte header declaring 6.4 GB of binary floats; an ASCII header
  // declaring 25 GB). The least bytes the voxel data can take: raw binary = the declared size;
  // ASCII = one character per voxel (plus separators); zlib/gzip = the declared size / 1032 (deflate
  // never compresses better). Checked after the checks above: GetImageSizeInBytes throws for an
  // unknown component type. bzip2 (NRRD) has no useful bound and is not checked.
  const auto voxels = static_cast<std::uintmax_t>(n);
  const auto declared = [&] { return static_cast<std::uintmax_t>(io->GetImageSizeInBytes()); };
  const auto require = [&](const fs::path& data, std::uintmax_t least, const char* what) {
    std::error_code size_ec;
    const auto have = fs::file_size(data, size_ec);
    if (!size_ec && have < least)
      throw InputError(path + ": cannot read the voxel data: truncated (the header declares " +
                       std::to_string(voxels) + " voxels, " + std::to_string(declared()) + " bytes, of " +
                       what + " voxel data, which needs at least " + std::to_string(least) + " bytes; " +
                       data.string() + " holds only " + std::to_string(have) + " bytes)");
  };
  if (auto* meta = dynamic_cast<itk::MetaImageIO*>(io.GetPointer())) {
    const MetaImage* mi = meta->GetMetaImagePointer();
    const fs::path data = metaimage_data_path(path, mi->ElementDataFileName());
    if (!mi->BinaryData())
      require(data, voxels, "ASCII");
    else if (mi->CompressedData())
      require(data, declared() / 1032, "compressed");
    else
      require(data, declared(), "raw binary");
  }
  if (std::string(io->GetNameOfClass()) == "NrrdImageIO") {
    std::ifstream in(path, std::ios::binary);
    std::string line, encoding = "raw";
    fs::path data = path;
    while (std::getline(in, line) && !line.empty() && line != "\r") {
      std::string lower = line;
      for (char& c : lower)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));  // teem: any case
      if (lower.rfind("encoding:", 0) == 0) encoding = lower.substr(9);
      if (lower.rfind("data file:", 0) == 0 || lower.rfind("datafile:", 0) == 0)
        data.clear();  // detached: not checked
    }
    const auto has = [&](const char* e) { return encoding.find(e) != std::string::npos; };
    if (!data.empty()) {
      if (has("raw"))
        require(data, declared(), "raw binary");
      else if (has("txt") || has("text") || has("ascii"))
        require(data, voxels, "ASCII");
      else if (has("hex"))
        require(data, 2 * declared(), "hex");
      else if (has("gz"))
        require(data, declared() / 1032, "gzip-compressed");
    }
  }
  return io;
}

// Voxel data that ITK 5.2 reads without complaint although it is short or corrupt (found by probing
// with hand-made files), checked independently before ITK reads it:
// - zlib-compressed MetaImage (CompressedData = True): MetaIO leaves the voxels of a short or corrupt
//   stream zero or garbage. The stream must inflate completely (Z_STREAM_END, which also checks its
//   Adler-32) to exactly the declared number of bytes.
// - ASCII MetaImage (BinaryData = False): MetaIO stops at the first token that is not a number and
//   fills the rest. The data must hold the declared number of values, each a whole number token.
// - NIfTI (.nii, .nii.gz): the reader zero-fills a short file. The (inflated) file must hold
//   vox_offset + the declared bytes.
// Data files with a non-zero MetaImage HeaderSize and NIfTI header/image pairs are left to ITK (lists
// and patterns of data files are refused by open_header).
class DataCheck {
 public:
  DataCheck(std::string path, std::uintmax_t voxels, std::uintmax_t bytes)
      : path_(std::move(path)), voxels_(voxels), bytes_(bytes) {}

  void metaimage(const MetaImage& mi) {
    const std::string value = mi.ElementDataFileName();
    const bool local = is_local_data(value);
    if (!local && mi.HeaderSize() != 0) return;
    const fs::path data = metaimage_data_path(path_, value);
    const std::uintmax_t offset = local ? local_data_offset() : 0;
    if (!mi.BinaryData())
      ascii(data, offset);
    else if (mi.CompressedData())
      inflated(data, offset);
  }

  void nifti() {
    const std::string name = fs::path(path_).filename().string();
    const auto ends = [&](const char* e) {
      const std::string x(e);
      return name.size() >= x.size() && name.compare(name.size() - x.size(), x.size(), x) == 0;
    };
    if (!ends(".nii") && !ends(".nii.gz")) return;
    gzFile f = gzopen(path_.c_str(), "rb");  // reads uncompressed files as they are
    if (!f) return;
    unsigned char h[544] = {};
    const int got = gzread(f, h, sizeof h);
    std::int32_t sizeof_hdr = 0;
    std::memcpy(&sizeof_hdr, h, 4);
    const bool swapped = sizeof_hdr != 348 && sizeof_hdr != 540;
    if (swapped)
      sizeof_hdr = static_cast<std::int32_t>(__builtin_bswap32(static_cast<std::uint32_t>(sizeof_hdr)));
    double vox_offset = 0.0;
    if (sizeof_hdr == 348 && got >= 348) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, h + 108, 4);
      if (swapped) bits = __builtin_bswap32(bits);
      float v = 0.0f;
      std::memcpy(&v, &bits, 4);
      vox_offset = std::max(static_cast<double>(v), 352.0);
    } else if (sizeof_hdr == 540 && got >= 540) {
      std::uint64_t bits = 0;
      std::memcpy(&bits, h + 168, 8);
      if (swapped) bits = __builtin_bswap64(bits);
      vox_offset = std::max(static_cast<double>(static_cast<std::int64_t>(bits)), 544.0);
    } else {
      gzclose(f);
      return;  // not a header this check understands; ITK has read it already
    }
    const bool compressed = ends(".gz");
    std::uintmax_t total = got > 0 ? static_cast<std::uintmax_t>(got) : 0;
    int n = 0;
    if (!compressed) {
      std::error_code ec;
      total = fs::file_size(path_, ec);  // an uncompressed file: no need to read it
    } else if (got == static_cast<int>(sizeof h)) {
      std::vector<unsigned char> buf(1 << 16);
      while ((n = gzread(f, buf.data(), static_cast<unsigned>(buf.size()))) > 0)
        total += static_cast<std::uintmax_t>(n);
    }
    int err = Z_OK;
    const std::string zmsg = n < 0 ? gzerror(f, &err) : "";
    gzclose(f);
    if (n < 0)
      throw InputError(path_ + ": cannot read the voxel data: corrupt compressed data (" + zmsg + ")");
    // A NaN, infinite or absurd offset (fuzz_nifti_header: NaN) would make the byte count undefined.
    if (!(vox_offset < 1e15)) {
      std::ostringstream v;
      v << vox_offset;
      throw InputError(
          path_ + ": NIfTI header vox_offset = " + v.str() +
          " is not a byte offset in a file (valid: a finite number of bytes, at least the header size)");
    }
    const auto need = static_cast<std::uintmax_t>(vox_offset) + bytes_;
    if (total < need)
      throw InputError(path_ + ": cannot read the voxel data: truncated (the header declares " +
                       std::to_string(voxels_) + " voxels, " + std::to_string(bytes_) + " bytes from byte " +
                       std::to_string(static_cast<std::uintmax_t>(vox_offset)) + ", but the " +
                       (compressed ? "inflated " : "") + "file holds only " + std::to_string(total) +
                       " bytes)");
  }

 private:
  // Byte after the line "ElementDataFile = LOCAL" (MetaIO requires it to be the last header line).
  std::uintmax_t local_data_offset() const {
    std::ifstream in(path_, std::ios::binary);
    std::string line;
    std::uintmax_t offset = 0;
    while (std::getline(in, line)) {
      offset += line.size() + 1;
      std::size_t b = line.find_first_not_of(" \t");
      if (b != std::string::npos && line.compare(b, 15, "ElementDataFile") == 0) return offset;
      if (offset > (1u << 20)) break;
    }
    throw InputError(path_ +
                     ": MetaImage header has no 'ElementDataFile = LOCAL' line before its voxel data");
  }

  void inflated(const fs::path& data, std::uintmax_t offset) const {
    std::ifstream in(data, std::ios::binary);
    if (!in) return;  // ITK reports an unreadable data file
    in.seekg(static_cast<std::streamoff>(offset));
    z_stream z{};
    if (inflateInit2(&z, 15 + 32) != Z_OK) throw std::runtime_error("zlib: inflateInit2 failed");
    std::vector<unsigned char> src(1 << 16), dst(1 << 16);
    std::uintmax_t out = 0;
    int rc = Z_OK;
    while (rc != Z_STREAM_END) {
      if (z.avail_in == 0) {
        in.read(reinterpret_cast<char*>(src.data()), static_cast<std::streamsize>(src.size()));
        z.avail_in = static_cast<uInt>(in.gcount());
        z.next_in = src.data();
        if (z.avail_in == 0) break;  // input ends before the stream does
      }
      z.next_out = dst.data();
      z.avail_out = static_cast<uInt>(dst.size());
      rc = inflate(&z, Z_NO_FLUSH);
      out += dst.size() - z.avail_out;
      if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR) break;
      if (out > bytes_) break;
    }
    const std::string msg = z.msg ? z.msg : "";
    inflateEnd(&z);
    if (rc != Z_STREAM_END && rc != Z_OK && rc != Z_BUF_ERROR)
      throw InputError(path_ + ": cannot read the voxel data: corrupt compressed data (zlib: " +
                       (msg.empty() ? "error " + std::to_string(rc) : msg) + ")");
    if (out > bytes_)
      throw InputError(path_ + ": cannot read the voxel data: the compressed data inflate to more than the " +
                       std::to_string(bytes_) + " bytes the header declares");
    if (rc != Z_STREAM_END)
      throw InputError(
          path_ + ": cannot read the voxel data: truncated compressed data (the stream ends after " +
          std::to_string(out) + " of the " + std::to_string(bytes_) + " bytes the header declares)");
    if (out != bytes_)
      throw InputError(path_ + ": cannot read the voxel data: the compressed data hold " +
                       std::to_string(out) + " bytes; the header declares " + std::to_string(voxels_) +
                       " voxels, " + std::to_string(bytes_) + " bytes");
  }

  void ascii(const fs::path& data, std::uintmax_t offset) const {
    std::ifstream in(data, std::ios::binary);
    if (!in) return;
    in.seekg(static_cast<std::streamoff>(offset));
    std::string token;
    for (std::uintmax_t k = 0; k < voxels_; ++k) {
      if (!(in >> token))
        throw InputError(path_ + ": cannot read the voxel data: truncated (the header declares " +
                         std::to_string(voxels_) + " ASCII values; the file holds " + std::to_string(k) +
                         ")");
      char* end = nullptr;
      const double v = std::strtod(token.c_str(), &end);
      if (end != token.c_str() + token.size() || token.empty())
        throw InputError(path_ + ": ASCII voxel " + std::to_string(k) + " is '" + token.substr(0, 40) +
                         "', not a number");
      if (!std::isfinite(v))
        throw InputError(path_ + ": ASCII voxel " + std::to_string(k) + " is '" + token.substr(0, 40) +
                         "'; every voxel must be a finite number");
    }
  }

  std::string path_;
  std::uintmax_t voxels_, bytes_;
};

// Temporary sibling that keeps the extension (ITK picks the writer from it): .NAME.tmpPID_K.EXT
fs::path temporary_image_path(const fs::path& final_path) {
  static int counter = 0;
  const std::string name = final_path.filename().string();
  std::string ext = final_path.extension().string();
  if (ext == ".gz") ext = fs::path(final_path.stem()).extension().string() + ext;  // .nii.gz
  const std::string stem = name.substr(0, name.size() - ext.size());
  return final_path.parent_path() /
         ("." + stem + ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + ext);
}

template <unsigned dim>
RawImage read_dim(const std::string& path, itk::ImageIOBase::Pointer io) {
  using ItkImage = itk::Image<float, dim>;
  auto reader = itk::ImageFileReader<ItkImage>::New();
  std::vector<itk::SizeValueType> checked(dim);
  for (unsigned a = 0; a < dim; ++a) checked[a] = io->GetDimensions(a);
  reader->SetImageIO(io);
  reader->SetFileName(path);
  {
    std::uintmax_t voxels = 1;
    for (unsigned a = 0; a < dim; ++a) voxels *= checked[a];
    DataCheck check(path, voxels, static_cast<std::uintmax_t>(io->GetImageSizeInBytes()));
    if (auto* meta = dynamic_cast<itk::MetaImageIO*>(io.GetPointer()))
      check.metaimage(*meta->GetMetaImagePointer());
    if (std::string(io->GetNameOfClass()) == "NiftiImageIO") check.nifti();
  }
  {
    StreamCapture capture;
    try {
      // MetaIO keeps state between the header reads ITK makes: a malformed header can give a
      // different (huge) size on the reader's own pass than the one open_header checked
      // (fuzz_image_header: regress_mha_second_pass_size, 25 GB allocated). The buffer is
      // allocated from the reader's pass, so it must match the checked one.
      reader->UpdateOutputInformation();
      const auto size = reader->GetOutput()->GetLargestPossibleRegion().GetSize();
      for (unsigned a = 0; a < dim; ++a)
        if (size[a] != checked[a])
          throw InputError(path + ": corrupt image header: it gives size " + std::to_string(size[a]) +
                           " along axis " + std::to_string(a) + " on a second read but " +
                           std::to_string(checked[a]) + " on the first");
      reader->Update();
    } catch (const itk::ExceptionObject& e) {
      throw InputError(path + ": cannot read the voxel data (truncated or corrupt file?): " +
                       one_line(capture.text() + " " + e.GetDescription()));
    } catch (const std::exception& e) {  // std::length_error, std::bad_alloc, ... from inside ITK
      throw InputError(path +
                       ": cannot read the voxel data (truncated or corrupt file?): " + one_line(e.what()));
    }
    const std::string said = capture.text();
    if (said.find("not read completely") != std::string::npos)
      throw InputError(
          path +
          ": cannot read the voxel data: truncated (the file holds fewer bytes than the header declares: " +
          one_line(said) + ")");
  }
  typename ItkImage::Pointer img = reader->GetOutput();
  RawImage out;
  const auto region = img->GetLargestPossibleRegion();
  std::size_t n = 1;
  for (unsigned a = 0; a < dim; ++a) {
    out.size.push_back(static_cast<long>(region.GetSize()[a]));
    n *= region.GetSize()[a];
    out.spacing.push_back(img->GetSpacing()[a]);
    out.origin.push_back(img->GetOrigin()[a]);
    for (unsigned b = 0; b < dim; ++b) out.direction.push_back(img->GetDirection()(a, b));
  }
  out.double_voxels = io->GetComponentType() == itk::IOComponentEnum::DOUBLE;
  const float* buf = img->GetBufferPointer();
  out.data.assign(buf, buf + n);  // ITK buffers are axis-0-fastest, as Image<dim>
  return out;
}

template <typename Pixel, unsigned dim>
void write_dim(const RawImage& image, const std::string& tmp) {
  using ItkImage = itk::Image<Pixel, dim>;
  auto img = ItkImage::New();
  typename ItkImage::SizeType size;
  typename ItkImage::SpacingType spacing;
  typename ItkImage::PointType origin;
  typename ItkImage::DirectionType direction;
  for (unsigned a = 0; a < dim; ++a) {
    size[a] = static_cast<itk::SizeValueType>(image.size[a]);
    spacing[a] = image.spacing[a];
    origin[a] = image.origin[a];
    for (unsigned b = 0; b < dim; ++b) direction(a, b) = image.direction[a * dim + b];
  }
  img->SetRegions(typename ItkImage::RegionType(size));
  img->SetSpacing(spacing);
  img->SetOrigin(origin);
  img->SetDirection(direction);
  img->Allocate();
  std::transform(image.data.begin(), image.data.end(), img->GetBufferPointer(),
                 [](float v) { return static_cast<Pixel>(v); });
  auto writer = itk::ImageFileWriter<ItkImage>::New();
  writer->SetFileName(tmp);
  writer->SetInput(img);
  writer->SetUseCompression(true);
  writer->Update();
}

}  // namespace

struct Header {
  std::string path;
  itk::ImageIOBase::Pointer io;
};

std::shared_ptr<Header> read_header(const std::string& path) {
  return std::make_shared<Header>(Header{path, open_header(path)});
}

int dimension(const Header& header) { return static_cast<int>(header.io->GetNumberOfDimensions()); }

int header_dimension(const std::string& path) { return dimension(*read_header(path)); }

RawImage read(const Header& header, int dim) {
  const std::string& path = header.path;
  const itk::ImageIOBase::Pointer& io = header.io;
  if (static_cast<int>(io->GetNumberOfDimensions()) != dim)
    throw InputError(path + ": image has " + std::to_string(io->GetNumberOfDimensions()) +
                     " dimensions; expected " + std::to_string(dim));
  return dim == 2 ? read_dim<2>(path, io) : read_dim<3>(path, io);
}

RawImage read(const std::string& path, int dim) { return read(*read_header(path), dim); }

void write(const RawImage& image, const std::string& path) {
  quiet_itk();
  const std::size_t dim = image.size.size();
  if ((dim != 2 && dim != 3) || image.spacing.size() != dim || image.origin.size() != dim ||
      image.direction.size() != dim * dim)
    throw std::invalid_argument(path + ": write_image: inconsistent image geometry");
  std::size_t n = 1;
  for (long s : image.size) n *= static_cast<std::size_t>(s);
  if (image.data.size() != n)
    throw std::invalid_argument(path + ": write_image: data size does not match the image size");
  if (image.labels)
    for (float v : image.data)
      if (!(v == std::round(v) && std::abs(v) <= 32767.0f))
        throw std::invalid_argument(path + ": write_label_image: label " + std::to_string(v) +
                                    " is not an integer in [-32767, 32767]");

  const fs::path final_path(path);
  const std::string ext = final_path.extension().string();
  if (ext == ".mhd" || ext == ".nhdr")
    throw std::invalid_argument(
        path + ": detached-header formats cannot be written atomically; use .mha, .nrrd, .nii or .nii.gz");
  const fs::path tmp = temporary_image_path(final_path);
  try {
    if (image.labels && dim == 2)
      write_dim<std::int16_t, 2>(image, tmp.string());
    else if (image.labels)
      write_dim<std::int16_t, 3>(image, tmp.string());
    else if (dim == 2)
      write_dim<float, 2>(image, tmp.string());
    else
      write_dim<float, 3>(image, tmp.string());
    fs::rename(tmp, final_path);
  } catch (const itk::ExceptionObject& e) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw std::runtime_error(path + ": cannot write image: " + one_line(e.GetDescription()));
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

}  // namespace vim::pipeline::itk_io
