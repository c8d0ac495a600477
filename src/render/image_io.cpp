#include "render/image_io.h"

#include <gif_lib.h>
#include <png.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "io/atomic_file.h"

namespace mosyn::render {

std::string encode_png(const Image& image) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width());
  png.height = static_cast<png_uint_32>(image.height());
  png.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.pixels().data(), 0, nullptr))
    throw Error(std::string("PNG encoding failed: ") + png.message);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.pixels().data(), 0, nullptr))
    throw Error(std::string("PNG encoding failed: ") + png.message);
  bytes.resize(size);
  return bytes;
}

Image decode_png(const std::string& bytes, const std::string& file_name_for_errors) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
    throw Error(file_name_for_errors + ": not a PNG image (" + png.message + ")");
  png.format = PNG_FORMAT_RGB;
  if (png.width == 0 || png.height == 0 || png.width > 16384 || png.height > 16384) {
    png_image_free(&png);
    throw Error(file_name_for_errors + ": PNG size out of range");
  }
  Image image(static_cast<int>(png.width), static_cast<int>(png.height));
  png_color black{0, 0, 0};
  if (!png_image_finish_read(&png, &black, image.pixels().data(), 0, nullptr))
    throw Error(file_name_for_errors + ": PNG decoding failed (" + png.message + ")");
  return image;
}

void write_png(const std::string& path, const Image& image) { io::write_file_atomically(path, encode_png(image)); }

Image read_png(const std::string& path) { return decode_png(io::read_file(path), path); }

std::vector<Rgb> gif_palette() {
  std::vector<Rgb> p;
  for (int r = 0; r < 6; ++r)
    for (int g = 0; g < 6; ++g)
      for (int b = 0; b < 6; ++b)
        p.push_back({static_cast<std::uint8_t>(51 * r), static_cast<std::uint8_t>(51 * g),
                     static_cast<std::uint8_t>(51 * b)});
  // Greys between the cube's grey levels, for smooth anti-aliasing on white.
  for (int i = 0; i < 40; ++i) {
    const auto v = static_cast<std::uint8_t>(std::lround(255.0 * (i + 1) / 41));
    p.push_back({v, v, v});
  }
  return p;
}

int gif_palette_index(Rgb c) {
  auto level = [](int v) { return std::clamp(static_cast<int>(std::lround(v / 51.0)), 0, 5); };
  const int cube = 36 * level(c.r) + 6 * level(c.g) + level(c.b);
  auto dist = [&](int r, int g, int b) { return (c.r - r) * (c.r - r) + (c.g - g) * (c.g - g) + (c.b - b) * (c.b - b); };
  int best = cube;
  int best_d = dist(51 * level(c.r), 51 * level(c.g), 51 * level(c.b));
  const int grey = (c.r + c.g + c.b) / 3;
  const int gi = std::clamp(static_cast<int>(std::lround(grey * 41.0 / 255.0)) - 1, 0, 39);
  for (int i = std::max(0, gi - 1); i <= std::min(39, gi + 1); ++i) {
    const int v = static_cast<int>(std::lround(255.0 * (i + 1) / 41));
    const int d = dist(v, v, v);
    if (d < best_d) {
      best_d = d;
      best = 216 + i;
    }
  }
  return best;
}

namespace {

int write_to_string(GifFileType* gif, const GifByteType* data, int length) {
  static_cast<std::string*>(gif->UserData)->append(reinterpret_cast<const char*>(data), static_cast<size_t>(length));
  return length;
}

struct ReadState {
  const std::string* bytes;
  size_t offset;
};

int read_from_string(GifFileType* gif, GifByteType* data, int length) {
  auto* s = static_cast<ReadState*>(gif->UserData);
  const size_t n = std::min(static_cast<size_t>(length), s->bytes->size() - s->offset);
  std::memcpy(data, s->bytes->data() + s->offset, n);
  s->offset += n;
  return static_cast<int>(n);
}

}  // namespace

std::string encode_gif(const std::vector<Image>& frames, int frame_delay_cs) {
  if (frames.empty()) throw Error("GIF needs at least one frame");
  const int w = frames[0].width(), h = frames[0].height();
  for (const auto& f : frames)
    if (f.width() != w || f.height() != h) throw Error("GIF frames differ in size");
  std::string out;
  int error = 0;
  GifFileType* gif = EGifOpen(&out, write_to_string, &error);
  if (!gif) throw Error(std::string("GIF encoding failed: ") + GifErrorString(error));
  auto fail = [&](const char* what) {
    const int code = gif->Error;
    EGifCloseFile(gif, &error);
    throw Error(std::string("GIF encoding failed at ") + what + ": " + GifErrorString(code));
  };
  const std::vector<Rgb> palette = gif_palette();
  std::vector<GifColorType> colors(256);
  for (int i = 0; i < 256; ++i) colors[i] = {palette[i].r, palette[i].g, palette[i].b};
  ColorMapObject* map = GifMakeMapObject(256, colors.data());
  EGifSetGifVersion(gif, true);
  const int ok = EGifPutScreenDesc(gif, w, h, 8, 0, map);
  GifFreeMapObject(map);
  if (ok == GIF_ERROR) fail("screen");
  // NETSCAPE2.0 application extension: loop forever.
  const unsigned char netscape[] = "NETSCAPE2.0";
  const unsigned char loop[] = {1, 0, 0};
  if (EGifPutExtensionLeader(gif, APPLICATION_EXT_FUNC_CODE) == GIF_ERROR ||
      EGifPutExtensionBlock(gif, 11, netscape) == GIF_ERROR || EGifPutExtensionBlock(gif, 3, loop) == GIF_ERROR ||
      EGifPutExtensionTrailer(gif) == GIF_ERROR)
    fail("loop extension");
  std::vector<GifPixelType> line(static_cast<size_t>(w));
  const int delay = std::clamp(frame_delay_cs, 1, 65535);
  for (const auto& f : frames) {
    const unsigned char control[4] = {0, static_cast<unsigned char>(delay & 0xff), static_cast<unsigned char>(delay >> 8),
                                      0};
    if (EGifPutExtension(gif, GRAPHICS_EXT_FUNC_CODE, 4, control) == GIF_ERROR) fail("frame delay");
    if (EGifPutImageDesc(gif, 0, 0, w, h, false, nullptr) == GIF_ERROR) fail("image");
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) line[x] = static_cast<GifPixelType>(gif_palette_index(f.at(x, y)));
      if (EGifPutLine(gif, line.data(), w) == GIF_ERROR) fail("pixels");
    }
  }
  if (EGifCloseFile(gif, &error) == GIF_ERROR) throw Error(std::string("GIF encoding failed: ") + GifErrorString(error));
  return out;
}

void write_gif(const std::string& path, const std::vector<Image>& frames, int frame_delay_cs) {
  io::write_file_atomically(path, encode_gif(frames, frame_delay_cs));
}

GifInfo decode_gif(const std::string& bytes) {
  ReadState state{&bytes, 0};
  int error = 0;
  GifFileType* gif = DGifOpen(&state, read_from_string, &error);
  if (!gif) throw Error(std::string("not a GIF: ") + GifErrorString(error));
  if (DGifSlurp(gif) == GIF_ERROR) {
    const int code = gif->Error;
    DGifCloseFile(gif, &error);
    throw Error(std::string("GIF decoding failed: ") + GifErrorString(code));
  }
  GifInfo info;
  info.width = gif->SWidth;
  info.height = gif->SHeight;
  info.num_frames = gif->ImageCount;
  if (gif->ImageCount > 0 && info.width > 0 && info.height > 0) {
    const SavedImage& s = gif->SavedImages[0];
    const ColorMapObject* map = s.ImageDesc.ColorMap ? s.ImageDesc.ColorMap : gif->SColorMap;
    info.first_frame = Image(info.width, info.height);
    for (int y = 0; y < s.ImageDesc.Height; ++y)
      for (int x = 0; x < s.ImageDesc.Width; ++x) {
        const GifColorType c = map->Colors[s.RasterBits[y * s.ImageDesc.Width + x]];
        info.first_frame.set(s.ImageDesc.Left + x, s.ImageDesc.Top + y, {c.Red, c.Green, c.Blue});
      }
  }
  DGifCloseFile(gif, &error);
  return info;
}

std::string find_on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::string dirs = path;
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = dirs.substr(start, end - start);
    if (!dir.empty()) {
      const std::string candidate = dir + "/" + program;
      struct stat st;
      if (::stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(candidate.c_str(), X_OK) == 0)
        return candidate;
    }
    start = end + 1;
  }
  return "";
}

namespace {
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}
}  // namespace

void write_mp4(const std::string& path, const std::vector<Image>& frames, double fps) {
  if (frames.empty()) throw Error("MP4 needs at least one frame");
  if (!(fps > 0)) throw Error("MP4 frame rate must be positive");
  const std::string ffmpeg = find_on_path("ffmpeg");
  if (ffmpeg.empty())
    throw Error("writing " + path +
                " needs ffmpeg, which is not on PATH: install it (e.g. apt-get install ffmpeg), or write .gif or .png");
  const int w = frames[0].width(), h = frames[0].height();
  for (const auto& f : frames)
    if (f.width() != w || f.height() != h) throw Error("MP4 frames differ in size");
  const std::string temp = path + ".tmp." + std::to_string(::getpid()) + ".mp4";
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", fps);
  const std::string cmd = shell_quote(ffmpeg) + " -hide_banner -loglevel error -y -f rawvideo -pix_fmt rgb24 -s " +
                          std::to_string(w) + "x" + std::to_string(h) + " -r " + rate +
                          " -i - -vf pad=ceil(iw/2)*2:ceil(ih/2)*2 -c:v libx264 -pix_fmt yuv420p -movflags +faststart " +
                          shell_quote(temp);
  FILE* pipe = ::popen(cmd.c_str(), "w");
  if (!pipe) throw Error("could not start ffmpeg for " + path);
  bool write_ok = true;
  for (const auto& f : frames)
    if (std::fwrite(f.pixels().data(), 1, f.pixels().size(), pipe) != f.pixels().size()) {
      write_ok = false;
      break;
    }
  const int status = ::pclose(pipe);
  std::error_code ec;
  if (!write_ok || status != 0) {
    std::filesystem::remove(temp, ec);
    throw Error("ffmpeg failed writing " + path + " (exit status " +
                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  }
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    throw Error("could not move the MP4 into place at " + path);
  }
}

}  // namespace mosyn::render
