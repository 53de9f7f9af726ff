// io::listImages: the one image lister behind `vslam detect --images` and
// `vslam vocab build --images`.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/image_files.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

void touch(const fs::path& path) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << "x";
}

// root/{b.JPG, a.png, notes.txt, depth/d.png, nested/inner/g.png, sub/e.webp, sub/deeper/f.pgm}
fs::path makeTree(const std::string& name) {
  const fs::path root = test::scratchDir(name);
  for (const char* file : {"b.JPG", "a.png", "notes.txt", "depth/d.png", "nested/inner/g.png", "sub/e.webp", "sub/deeper/f.pgm"})
    touch(root / file);
  return root;
}

TEST(IoImageFiles, RecognisesImageExtensionsWhateverTheCase) {
  for (const char* name : {"x.jpg", "x.JPEG", "x.Png", "x.bmp", "x.tif", "x.tiff", "x.ppm", "x.pgm", "x.webp"})
    EXPECT_TRUE(isImageFile(name)) << name;
  for (const char* name : {"x.txt", "x", "png", "x.png.bak", "x.yaml"}) EXPECT_FALSE(isImageFile(name)) << name;
}

TEST(IoImageFiles, FolderWithoutRecursionListsItsOwnImagesSorted) {
  const fs::path root = makeTree("io_images_flat");
  const std::vector<fs::path> images = listImages({root.string()});
  ASSERT_EQ(images.size(), 2u);
  EXPECT_EQ(images[0], root / "a.png");
  EXPECT_EQ(images[1], root / "b.JPG");
}

TEST(IoImageFiles, RecursiveSkipsNamedFoldersAndKeepsInputOrder) {
  const fs::path root = makeTree("io_images_deep");
  const fs::path single = root / "sub" / "e.webp";
  const std::vector<fs::path> images = listImages({single.string(), root.string()}, {true, {"depth"}});
  const std::vector<fs::path> expected = {single, root / "a.png", root / "b.JPG", root / "nested" / "inner" / "g.png",
                                          root / "sub" / "deeper" / "f.pgm",
                                          root / "sub" / "e.webp"};
  EXPECT_EQ(images, expected);
}

TEST(IoImageFiles, BadInputsNameThePath) {
  const fs::path root = makeTree("io_images_bad");
  const auto message = [](const std::vector<std::string>& inputs, const ImageListOptions& options) {
    try {
      listImages(inputs, options);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message({(root / "missing").string()}, {}), (root / "missing").string() + ": no such image file or folder");
  EXPECT_EQ(message({(root / "notes.txt").string()}, {}),
            (root / "notes.txt").string() + ": not an image (.jpg, .png, .bmp, .tif, .ppm, .pgm, .webp)");
  EXPECT_EQ(message({(root / "nested").string()}, {}),
            (root / "nested").string() + ": folder holds no images (sub-folders not searched)");
  EXPECT_EQ(message({(root / "depth").string()}, {true, {"depth"}}), "no error");  // the input itself is searched
}

}  // namespace
}  // namespace vslam
