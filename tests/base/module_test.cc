#include "base/module.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace fesim {
namespace {

// A module of the build (apps/matfile_module.h) that this test depends on.
constexpr char kBuiltModule[] = "fesim_matio.so";
constexpr char kBuiltFactory[] = "fesim_mat_create";

std::string ErrorOf(const std::string& file, const char* symbol) {
  try {
    ModuleSymbol(file, symbol, "the purpose");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(ModuleSymbol, FindsTheFactoryOfABuiltModule) {
  EXPECT_NE(ModuleSymbol(kBuiltModule, kBuiltFactory, "test"), nullptr);
  // Again: the module stays loaded and the same address comes back.
  EXPECT_EQ(ModuleSymbol(kBuiltModule, kBuiltFactory, "test"),
            ModuleSymbol(kBuiltModule, kBuiltFactory, "test"));
}

TEST(ModuleSymbol, MissingModuleIsOneLineNamingItAndThePurpose) {
  const std::string message = ErrorOf("fesim_no_such_module.so", "f");
  ASSERT_FALSE(message.empty());
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_NE(message.find("the purpose"), std::string::npos) << message;
  EXPECT_NE(message.find("fesim_no_such_module.so"), std::string::npos) << message;
  EXPECT_NE(message.find(ModuleSearchPath()), std::string::npos) << message;
}

TEST(ModuleSymbol, MissingSymbolIsNamed) {
  const std::string message = ErrorOf(kBuiltModule, "fesim_no_such_factory");
  ASSERT_FALSE(message.empty());
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_NE(message.find("fesim_no_such_factory"), std::string::npos) << message;
}

TEST(ModuleSearchPath, StartsWithTheDirectoryOfThisExecutable) {
  const std::string path = ModuleSearchPath();
  ASSERT_FALSE(path.empty());
  EXPECT_EQ(path[0], '/') << path;  // absolute, whatever the working directory
  EXPECT_EQ(path.find("::"), std::string::npos) << path;
}

}  // namespace
}  // namespace fesim
