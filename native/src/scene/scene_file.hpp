// Reading a scene file: a TOML table plus --set overrides, read through a
// checked accessor. Every key read is recorded; keys never read are an error,
// as is a wrong type or a value out of range. Errors name the file, the key
// and the reason. Defaults are written back into the table, so the resolved
// scene (file + overrides + defaults) can be printed and stored with the output.
#pragma once
#include <toml++/toml.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace granular {

class SceneError : public std::runtime_error {
 public:
  SceneError(const std::string& file, const std::string& key, const std::string& reason)
      : std::runtime_error(file + ": key '" + key + "': " + reason) {}
  SceneError(const std::string& file, const std::string& reason) : std::runtime_error(file + ": " + reason) {}
};

class SceneFile {
 public:
  // Parses `path` and applies overrides of the form "dotted.key=value"; the
  // value is read as a TOML value (60, 0.5, "capped", true), or as a bare
  // string if it is not one.
  SceneFile(const std::string& path, const std::vector<std::string>& overrides);

  const std::string& path() const { return path_; }

  double number(const std::string& key);
  double number(const std::string& key, double fallback);
  long integer(const std::string& key);
  long integer(const std::string& key, long fallback);
  std::string text(const std::string& key);
  std::string text(const std::string& key, const std::string& fallback);
  std::string choice(const std::string& key, const std::vector<std::string>& allowed);
  std::string choice(const std::string& key, const std::vector<std::string>& allowed, const std::string& fallback);
  bool flag(const std::string& key, bool fallback);
  bool has(const std::string& key) const;
  // A string value without marking the key as read (to choose the scene reader).
  std::string peek_text(const std::string& key) const;

  // Range checks that raise SceneError naming this file and key.
  double positive(const std::string& key, double v) const;
  double non_negative(const std::string& key, double v) const;
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const;

  // After every reader ran: any key present but never read is an error.
  void reject_unknown_keys() const;

  std::string resolved_toml() const;
  std::string resolved_json() const;

 private:
  const toml::node* find(const std::string& key) const;
  void set_default(const std::string& key, toml::node&& value);
  template <class T>
  void set_default_value(const std::string& key, T value);

  std::string path_;
  toml::table table_;
  std::set<std::string> used_;
};

}  // namespace granular
