// Reading a scene file: a TOML table plus --set overrides, read through a
// checked accessor. Every key read is recorded; keys never read are an error,
// as is a wrong type or a value out of range. Errors name the file, the line
// of the key in the file (when the key is in the file), the key and the reason,
// in one line (docs/errors.md). Defaults are written back into the table, so
// the resolved scene (file + overrides + defaults) can be printed and stored
// with the output.
#pragma once
#include <toml++/toml.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace granular {

// What one run can hold: particles (about 0.5 kB each with the neighbour list,
// so 5e7 fill this machine's 24 GiB) and steps (counted in a 64-bit integer
// with room to spare). Scenes beyond them are refused when read.
constexpr double kMaxParticles = 5e7;
constexpr double kMaxSteps = 1e15;

// A number as messages print it (shortest of the stream's default format).
std::string number_text(double v);

class SceneError : public std::runtime_error {
 public:
  // "file:line: key: reason"; line 0 (a default, a --set override, a missing
  // key) leaves the line out. `key` may carry a note such as " (--set)".
  SceneError(const std::string& file, long line, const std::string& key, const std::string& reason);
  SceneError(const std::string& file, const std::string& key, const std::string& reason)
      : SceneError(file, 0, key, reason) {}
  // An error about the file as a whole ("file: reason", or "file:line: reason").
  SceneError(const std::string& file, const std::string& reason) : std::runtime_error(file + ": " + reason) {}
};

class SceneFile {
 public:
  // Parses `path` and applies overrides of the form "dotted.key=value"; the
  // value is read as a TOML value (60, 0.5, "capped", true), or as a bare
  // string if it is not one.
  SceneFile(const std::string& path, const std::vector<std::string>& overrides);
  // A scene from text (the built-in minimal scenes that list a kind's keys).
  static SceneFile from_text(const std::string& text, const std::string& name);

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
  // An array (of values, inline tables or tables: [[wall]]); its elements are
  // the caller's to check, naming the key and the element's line (fail_at).
  const toml::array& array(const std::string& key);
  bool has(const std::string& key) const;
  // A string value without marking the key as read (to choose the scene reader).
  std::string peek_text(const std::string& key) const;

  // Where a key's value comes from, for messages that name a second key:
  // "line 12", "--set" or "default".
  std::string origin(const std::string& key) const;
  // The key's line in the file, 0 when it is not there (default, --set, missing).
  long line_of(const std::string& key) const;

  // Range checks that raise SceneError naming this file and key.
  double positive(const std::string& key, double v) const;
  double non_negative(const std::string& key, double v) const;
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const;
  // The same at a given line of the file (an element of an array), or at the
  // key's own line where `line` is 0.
  [[noreturn]] void fail_at(long line, const std::string& key, const std::string& reason) const;

  // After every reader ran: any key present but never read is an error, with
  // the nearest key the reader knows as a suggestion.
  void reject_unknown_keys() const;
  // Before reading: any key not in `known` (every key a reader of this scene
  // kind reads) is an error, reported before a missing or invalid value, since
  // a misspelt key often causes those.
  void reject_keys_outside(const std::vector<std::string>& known) const;
  // The keys read so far.
  std::vector<std::string> read_keys() const;

  // Every key `read_fields` reads, found by reading `minimal`, a complete
  // built-in scene of that kind.
  template <class ReadFields>
  static std::vector<std::string> keys_read_by(ReadFields read_fields, const char* minimal, const char* name) {
    SceneFile m = from_text(minimal, name);
    read_fields(m);
    return m.read_keys();
  }
  // A whole scene read with its key checks: keys outside `known` first, then
  // the values, then any key left unread.
  template <class ReadFields>
  auto read_checked(ReadFields read_fields, const std::vector<std::string>& known) {
    reject_keys_outside(known);
    auto s = read_fields(*this);
    reject_unknown_keys();
    return s;
  }

  std::string resolved_toml() const;
  std::string resolved_json() const;

 private:
  SceneFile() = default;
  const toml::node* find(const std::string& key) const;
  [[noreturn]] void missing(const std::string& key) const;
  // Fails for an unknown key; returns for an empty table of a known name.
  void unknown(const std::string& key, const std::vector<std::string>& known) const;
  std::vector<std::string> keys_in_order() const;  // file order, --set overrides first
  void set_default(const std::string& key, toml::node&& value);
  template <class T>
  void set_default_value(const std::string& key, T value);

  std::string path_;
  toml::table table_;
  std::set<std::string> used_;
  std::set<std::string> overridden_;  // keys set by --set (their source is not the file)
  std::set<std::string> defaulted_;   // keys absent from the file, given their default
};

// The closest of `candidates` to `word` (case-insensitive edit distance, with
// transpositions), or "" when none is close enough to be a likely misspelling.
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace granular
