// JPEG colour images (libjpeg-turbo): the colour frames of the Redwood / Open3D RGB-D layout and of
// many hand-held RGB-D recordings. Declared in obm/io/rgbd.hpp next to the PNG readers.
// jpeglib.h needs size_t and FILE declared before it.
#include <algorithm>
#include <csetjmp>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include <jpeglib.h>
#include <jerror.h>  // JWRN_JPEG_EOF, JWRN_HIT_MARKER

#include "obm/core/errors.hpp"
#include "obm/io/rgbd.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace {

/// libjpeg reports fatal errors through error_exit, which must not return: it jumps back to the
/// decoder with the message kept here.
struct JpegErrorSink {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {0};
};

void jpegErrorExit(j_common_ptr cinfo) {
  auto* sink = reinterpret_cast<JpegErrorSink*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, sink->message);
  std::longjmp(sink->jump, 1);
}

void jpegOutputMessage(j_common_ptr) {}  // warnings (corrupt-data recoveries) are not printed

/// Warnings are recoveries from corrupt data and are let pass, except the end of the image data
/// before the image's end (the file ends, or a marker comes where pixels should): libjpeg would
/// then decode the missing rows as grey, which for a corrupt header claiming 10^8 pixels is
/// seconds of work and hundreds of MB for a few hundred bytes of file (two fuzzing findings), and
/// for a real frame is an image whose lower part is invented. Such a frame is an error.
void jpegEmitMessage(j_common_ptr cinfo, int level) {
  if (level < 0 && (cinfo->err->msg_code == JWRN_JPEG_EOF || cinfo->err->msg_code == JWRN_HIT_MARKER))
    jpegErrorExit(cinfo);
}

/// The largest image accepted (8192 x 8192; colour frames of depth cameras are at most a few
/// megapixels), so that a corrupt header cannot ask for gigabytes.
constexpr std::size_t kMaxPixels = std::size_t{1} << 26;

struct JpegPixels {
  unsigned width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::string format_error;
};

/// 0 = decoded, 1 = libjpeg error (message in the sink), 2 = unusable image (out->format_error).
/// Only plain data lives in this frame across setjmp: the output is owned by the caller.
int jpegDecode(jpeg_decompress_struct* cinfo, JpegErrorSink* sink, std::FILE* fp,
               JpegPixels* out) {
  if (setjmp(sink->jump)) return 1;
  jpeg_stdio_src(cinfo, fp);
  jpeg_read_header(cinfo, TRUE);
  // The size is checked before jpeg_start_decompress: for a progressive image that call already
  // allocates and zeroes the whole image's coefficients (a fuzzing finding: a 182-byte header
  // claiming 270 Mpx cost 7 s and gigabytes before its scans were found invalid).
  if (cinfo->image_width == 0 || cinfo->image_height == 0 ||
      std::size_t(cinfo->image_width) * std::size_t(cinfo->image_height) > kMaxPixels) {
    out->format_error = "image size " + std::to_string(cinfo->image_width) + "x" +
                        std::to_string(cinfo->image_height) + " out of range";
    return 2;
  }
  cinfo->out_color_space = JCS_RGB;  // grey and YCbCr are converted; CMYK is refused below
  jpeg_start_decompress(cinfo);
  if (cinfo->output_components != 3) {
    out->format_error = "cannot convert " + std::to_string(cinfo->output_components) +
                        "-component JPEG to RGB";
    jpeg_abort_decompress(cinfo);
    return 2;
  }
  out->width = cinfo->output_width;  // no scaling: the size checked above
  out->height = cinfo->output_height;
  const std::size_t rowbytes = std::size_t(out->width) * 3;
  while (cinfo->output_scanline < cinfo->output_height) {
    // The buffer grows with the rows decoded, so a stream that ends early fails before the
    // whole image the header claims is allocated.
    const std::size_t end = std::size_t(cinfo->output_scanline + 1) * rowbytes;
    if (out->rgb.size() < end)
      out->rgb.resize(std::min(std::size_t(out->height) * rowbytes, std::max(end, 2 * out->rgb.size())));
    JSAMPROW row = out->rgb.data() + std::size_t(cinfo->output_scanline) * rowbytes;
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  return 0;
}

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};

}  // namespace

ColorImage readColorJpeg(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> fp(std::fopen(path.c_str(), "rb"));
  if (!fp) throw IoError("cannot open '" + path + "' for reading: " + std::strerror(errno));
  unsigned char soi[2] = {0, 0};
  if (std::fread(soi, 1, 2, fp.get()) != 2 || soi[0] != 0xFF || soi[1] != 0xD8)
    throw FormatError(path, 0, "not a JPEG file");
  std::rewind(fp.get());
  jpeg_decompress_struct cinfo;
  JpegErrorSink sink;
  cinfo.err = jpeg_std_error(&sink.mgr);
  sink.mgr.error_exit = jpegErrorExit;
  sink.mgr.output_message = jpegOutputMessage;
  sink.mgr.emit_message = jpegEmitMessage;
  jpeg_create_decompress(&cinfo);
  JpegPixels px;
  const int rc = jpegDecode(&cinfo, &sink, fp.get(), &px);
  jpeg_destroy_decompress(&cinfo);
  if (rc == 1) throw FormatError(path, 0, std::string("corrupt JPEG: ") + sink.message);
  if (rc == 2) throw FormatError(path, 0, px.format_error);
  ColorImage img;
  img.width = static_cast<int>(px.width);
  img.height = static_cast<int>(px.height);
  img.rgb = std::move(px.rgb);
  return img;
}

ColorImage readColorImage(const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == "png") return readColorPng(path);
  if (ext == "jpg" || ext == "jpeg") return readColorJpeg(path);
  throw IoError("cannot read colour image '" + path + "': only PNG and JPEG are supported");
}

}  // namespace obm::io
