// Checks a screenshot shows a scene, not an empty frame: the share of pixels that differ from the
// background (the corner pixel's colour) and the share in the first object's colour (orange: red
// well above green and blue; the viewer's palette gives it to the first non-collider object).
//
//   png_coverage FILE.png MIN_COVERED MIN_FIRST_OBJECT     exit 0 when both shares are reached
#include <cstdio>
#include <cstdlib>
#include <memory>

#include <stb/stb_image.h>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: png_coverage FILE.png MIN_COVERED MIN_FIRST_OBJECT\n");
    return 2;
  }
  int width = 0, height = 0, channels = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> pixels(
      stbi_load(argv[1], &width, &height, &channels, 3), stbi_image_free);
  if (!pixels) {
    std::fprintf(stderr, "%s: not a readable PNG\n", argv[1]);
    return 1;
  }
  const unsigned char* p = pixels.get();
  const int background[3] = {p[0], p[1], p[2]};
  long covered = 0, first = 0;
  const long total = long(width) * height;
  for (long i = 0; i < total; ++i) {
    const int r = p[3 * i], g = p[3 * i + 1], b = p[3 * i + 2];
    covered +=
        std::abs(r - background[0]) + std::abs(g - background[1]) + std::abs(b - background[2]) >
        30;
    first += r > g + 40 && r > b + 60;
  }
  const double coveredShare = double(covered) / total, firstShare = double(first) / total;
  std::printf(
      "%s: %dx%d, %.1f%% differs from the background, %.1f%% in the first object's colour\n",
      argv[1], width, height, 100 * coveredShare, 100 * firstShare);
  return coveredShare >= std::atof(argv[2]) && firstShare >= std::atof(argv[3]) ? 0 : 1;
}
