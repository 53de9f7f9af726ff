#include "vslam/io/image_files.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <set>

#include "vslam/core/error.hpp"

namespace vslam {

namespace fs = std::filesystem;

bool isImageFile(const fs::path& path) {
  static const std::set<std::string> kExtensions = {".jpg", ".jpeg", ".png",  ".bmp", ".tif",
                                                    ".tiff", ".ppm", ".pgm", ".webp"};
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return kExtensions.count(extension) > 0;
}

std::string imageTruncation(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  char head[8] = {};
  in.read(head, sizeof(head));
  const std::string start(head, static_cast<size_t>(in.gcount()));
  const bool jpeg = start.size() >= 2 && start[0] == '\xFF' && start[1] == '\xD8';
  const bool png = start.size() == 8 && start == "\x89PNG\r\n\x1A\n";
  if (!jpeg && !png) return "";
  // Writers may pad after the end (a few zero bytes): look for it in the tail.
  constexpr std::streamoff kTail = 32;
  in.clear();
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(std::max<std::streamoff>(0, size - kTail));
  std::string tail(static_cast<size_t>(std::min(size, kTail)), '\0');
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  if (jpeg && tail.find("\xFF\xD9") == std::string::npos)
    return "truncated JPEG: no end-of-image marker (FF D9) at its end";
  // The IEND chunk is always the same bytes: type and CRC.
  if (png && tail.find(std::string("IEND\xAE\x42\x60\x82", 8)) == std::string::npos)
    return "truncated PNG: no IEND chunk at its end";
  return "";
}

namespace {

std::vector<fs::path> imagesInFolder(const std::string& folder, const ImageListOptions& options) {
  const auto skipped = [&](const fs::path& path) {
    return std::find(options.skipped_folders.begin(), options.skipped_folders.end(), path.filename().string()) !=
           options.skipped_folders.end();
  };
  std::vector<fs::path> found;
  if (options.recursive) {
    for (auto it = fs::recursive_directory_iterator(folder, fs::directory_options::follow_directory_symlink);
         it != fs::recursive_directory_iterator(); ++it) {
      if (it->is_directory() && skipped(it->path())) {
        it.disable_recursion_pending();
        continue;
      }
      if (it->is_regular_file() && isImageFile(it->path())) found.push_back(it->path());
    }
  } else {
    for (const auto& entry : fs::directory_iterator(folder))
      if (entry.is_regular_file() && isImageFile(entry.path())) found.push_back(entry.path());
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace

std::vector<fs::path> listImages(const std::vector<std::string>& inputs, const ImageListOptions& options) {
  std::vector<fs::path> images;
  for (const std::string& input : inputs) {
    std::error_code error;
    const fs::file_status status = fs::status(input, error);
    if (error || !fs::exists(status)) throw InputError(input, 0, "no such image file or folder");
    if (fs::is_regular_file(status)) {
      if (!isImageFile(input)) throw InputError(input, 0, "not an image (.jpg, .png, .bmp, .tif, .ppm, .pgm, .webp)");
      images.emplace_back(input);
      continue;
    }
    std::vector<fs::path> found;
    try {
      found = imagesInFolder(input, options);
    } catch (const fs::filesystem_error& e) {
      throw InputError(input, 0, std::string("cannot list the folder: ") + e.code().message());
    }
    if (found.empty()) {
      std::string where = options.recursive ? " (searched recursively" : " (sub-folders not searched";
      for (const std::string& name : options.skipped_folders) where += ", " + name + "/ skipped";
      throw InputError(input, 0, "folder holds no images" + where + ")");
    }
    images.insert(images.end(), found.begin(), found.end());
  }
  return images;
}

}  // namespace vslam
