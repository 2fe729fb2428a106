// Scene paths are resolved (symlinks, "..") before they are checked
// against the roots: nothing outside a root is served, and the errors
// distinguish "not allowed" from "not there".
#include "server/service/scene_roots.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>

#include <fstream>

namespace fs = std::filesystem;

namespace pbgi::service {
namespace {

class SceneRootsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root = tmp.path() / "scenes";
    fs::create_directories(root / "sub");
    fs::create_directories(tmp.path() / "outside");
    fs::create_directories(tmp.path() / "scenes-evil");
    touch(root / "a.usda");
    touch(root / "sub" / "b.usda");
    touch(tmp.path() / "outside" / "secret.usda");
    touch(tmp.path() / "scenes-evil" / "c.usda");
    fs::create_symlink(tmp.path() / "outside" / "secret.usda", root / "escape.usda");
    fs::create_symlink(tmp.path() / "outside", root / "outside-dir");
    fs::create_symlink(root / "sub" / "b.usda", root / "alias.usda");
  }
  static void touch(const fs::path& p) { std::ofstream(p) << "#usda 1.0\n"; }

  template <class E>
  std::string expect_throw(const SceneRoots& roots, const std::string& request) {
    try {
      roots.resolve(request);
    } catch (const E& e) {
      return e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << request << ": wrong exception: " << e.what();
      return "";
    }
    ADD_FAILURE() << request << ": resolved, expected an error";
    return "";
  }

  testing::TempDir tmp;
  fs::path root;
};

TEST_F(SceneRootsTest, ResolvesFilesInsideTheRoot) {
  SceneRoots roots({root});
  const fs::path canonical_root = fs::canonical(root);
  EXPECT_EQ(roots.resolve((root / "a.usda").string()), canonical_root / "a.usda");
  EXPECT_EQ(roots.resolve("a.usda"), canonical_root / "a.usda");          // relative: below a root
  EXPECT_EQ(roots.resolve("sub/../a.usda"), canonical_root / "a.usda");
  EXPECT_EQ(roots.resolve("alias.usda"), canonical_root / "sub" / "b.usda");  // symlink inside
}

TEST_F(SceneRootsTest, RefusesPathsOutsideEveryRoot) {
  SceneRoots roots({root});
  EXPECT_NE(expect_throw<PermissionDenied>(roots, "/etc/passwd").find("/etc/passwd"),
            std::string::npos);
  EXPECT_NE(expect_throw<PermissionDenied>(roots, "../outside/secret.usda").find("../outside"),
            std::string::npos);
  expect_throw<PermissionDenied>(roots, (root / ".." / "outside" / "secret.usda").string());
  // Symlinks are followed before the check.
  expect_throw<PermissionDenied>(roots, "escape.usda");
  expect_throw<PermissionDenied>(roots, "outside-dir/secret.usda");
  // A missing file behind a symlink that leaves the root is still refused,
  // not reported missing (that would reveal what exists outside).
  expect_throw<PermissionDenied>(roots, "outside-dir/nothing.usda");
  // A sibling whose name merely starts with the root's is outside.
  expect_throw<PermissionDenied>(roots, (tmp.path() / "scenes-evil" / "c.usda").string());
}

TEST_F(SceneRootsTest, RefusalsDoNotDiscloseWhereASymlinkLeads) {
  SceneRoots roots({root});
  const std::string outside = fs::canonical(tmp.path() / "outside").string();
  for (const char* request : {"escape.usda", "outside-dir/secret.usda", "outside-dir/nothing.usda"}) {
    const std::string message = expect_throw<PermissionDenied>(roots, request);
    EXPECT_NE(message.find(request), std::string::npos) << message;
    EXPECT_EQ(message.find(outside), std::string::npos) << "discloses the symlink's target: " << message;
  }
}

TEST_F(SceneRootsTest, NulInTheRequestIsRefused) {
  SceneRoots roots({root});
  // The kernel would open "a.usda": the request named something else.
  const std::string message = expect_throw<InvalidArgument>(roots, std::string("a.usda\0../../x", 15));
  EXPECT_NE(message.find("NUL"), std::string::npos) << message;
  expect_throw<InvalidArgument>(roots, std::string("\0", 1));
}

TEST_F(SceneRootsTest, MissingInsideIsNotFound) {
  SceneRoots roots({root});
  const std::string message = expect_throw<NotFound>(roots, "missing.usda");
  EXPECT_NE(message.find("missing.usda"), std::string::npos) << message;
  expect_throw<NotFound>(roots, (root / "sub" / "nope.usda").string());
}

TEST_F(SceneRootsTest, DirectoriesAndEmptyRequestsAreInvalid) {
  SceneRoots roots({root});
  expect_throw<InvalidArgument>(roots, "sub");
  expect_throw<InvalidArgument>(roots, "");
}

TEST_F(SceneRootsTest, SeveralRootsAreSearchedInOrder) {
  SceneRoots roots({tmp.path() / "outside", root});
  EXPECT_EQ(roots.resolve("a.usda"), fs::canonical(root) / "a.usda");
  EXPECT_EQ(roots.resolve("secret.usda"), fs::canonical(tmp.path() / "outside") / "secret.usda");
}

TEST_F(SceneRootsTest, NoRootsRefusesEverything) {
  SceneRoots roots({});
  expect_throw<PermissionDenied>(roots, (root / "a.usda").string());
}

TEST_F(SceneRootsTest, MissingRootIsAnError) {
  EXPECT_THROW(SceneRoots({tmp.path() / "no-such-dir"}), IoError);
}

}  // namespace
}  // namespace pbgi::service
