// Writing rendered images: PNG (libpng), animated GIF (giflib, fixed palette) and MP4 (frames piped
// to an external ffmpeg). All files are written atomically (io/atomic_file.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "render/canvas.h"

namespace mosyn::render {

// PNG bytes (8-bit RGB) of an image. Throws mosyn::Error when libpng fails.
std::string encode_png(const Image& image);
// Decodes PNG bytes of any colour type to 8-bit RGB (alpha composited on black). Throws
// mosyn::Error naming file_name_for_errors when the bytes are not a PNG.
Image decode_png(const std::string& bytes, const std::string& file_name_for_errors = "PNG data");
void write_png(const std::string& path, const Image& image);
Image read_png(const std::string& path);

// The fixed 256-colour GIF palette: a 6x6x6 colour cube (channel levels 0, 51, ..., 255; index
// 36 r + 6 g + b) followed by 40 greys. Returns [256] colours.
std::vector<Rgb> gif_palette();
// Index of the palette colour nearest to c (squared RGB distance; the cube cell, or a grey when
// that is nearer).
int gif_palette_index(Rgb c);

// Animated GIF bytes of equally sized frames shown frame_delay_cs hundredths of a second each,
// looping forever. Throws mosyn::Error for no frames, differing sizes or a giflib failure.
std::string encode_gif(const std::vector<Image>& frames, int frame_delay_cs);
void write_gif(const std::string& path, const std::vector<Image>& frames, int frame_delay_cs);
// Decodes a GIF's frame count, size and the palette colours of its first frame (for tests).
struct GifInfo {
  int width = 0, height = 0, num_frames = 0;
  Image first_frame;
};
GifInfo decode_gif(const std::string& bytes);

// Full path of an executable found on PATH, or "" when none.
std::string find_on_path(const std::string& program);

// Writes an H.264 MP4 of the frames at fps by piping raw RGB to `ffmpeg` (found on PATH) into a
// temporary file that is renamed over path when ffmpeg succeeds. Odd sizes are padded to even.
// Throws mosyn::Error with an installation hint when ffmpeg is not on PATH, and with ffmpeg's exit
// status when it fails.
void write_mp4(const std::string& path, const std::vector<Image>& frames, double fps);

}  // namespace mosyn::render
