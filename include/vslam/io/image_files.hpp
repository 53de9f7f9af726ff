#pragma once
// Lists the image files named on a command line: `vslam detect --images` and
// `vslam vocab build --images` take files and folders alike.
#include <filesystem>
#include <string>
#include <vector>

namespace vslam {

struct ImageListOptions {
  bool recursive = false;  // search folders' sub-folders too
  // Sub-folders with these names are not searched (e.g. TUM's depth/, whose
  // 16-bit PNGs are depth maps, not photographs).
  std::vector<std::string> skipped_folders;
};

// True for the image formats OpenCV reads (.jpg, .jpeg, .png, .bmp, .tif,
// .tiff, .ppm, .pgm, .webp), whatever the letter case.
bool isImageFile(const std::filesystem::path& path);

// Why the image file at `path` is cut short, or "" when it is whole (or of
// another format). A JPEG must end with its end-of-image marker (FF D9) and a
// PNG with its IEND chunk: OpenCV decodes a truncated file into a partial
// image without an error (libjpeg only prints a warning), so a copy that was
// interrupted would otherwise be tracked as a real frame.
std::string imageTruncation(const std::filesystem::path& path);

// Every input is an image file or a folder of images. Returns the images,
// inputs in the order given, each folder's images sorted by path. Throws
// InputError naming the input when it does not exist, is a file that is not an
// image, or is a folder holding none.
std::vector<std::filesystem::path> listImages(const std::vector<std::string>& inputs,
                                              const ImageListOptions& options = {});

}  // namespace vslam
