#include "scene/scene_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <sstream>

namespace granular {

SceneError::SceneError(const std::string& file, long line, const std::string& key, const std::string& reason)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                         (key.empty() ? std::string() : key + ": ") + reason) {}

namespace {

std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::stringstream ss(key);
  std::string part;
  while (std::getline(ss, part, '.')) parts.push_back(part);
  return parts;
}

// The table holding the last part of a dotted key, creating tables on the way.
toml::table* table_for(toml::table& root, const std::vector<std::string>& parts, const std::string& file,
                       const std::string& key) {
  toml::table* t = &root;
  for (std::size_t q = 0; q + 1 < parts.size(); ++q) {
    auto* node = t->get(parts[q]);
    if (!node) {
      t->insert(parts[q], toml::table{});
      node = t->get(parts[q]);
    }
    t = node->as_table();
    if (!t) throw SceneError(file, key, "goes through '" + parts[q] + "', which is not a table");
  }
  return t;
}

// Every leaf key (dotted), and every empty table, of a table.
void collect_keys(const toml::table& t, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& [k, v] : t) {
    const std::string full = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    const auto* sub = v.as_table();
    if (sub && !sub->empty())
      collect_keys(*sub, full, out);
    else
      out.push_back(full);
  }
}

// What a value is, for "must be a number, got ..." messages.
std::string describe(const toml::node& n) {
  std::ostringstream os;
  if (n.is_string()) os << "the string \"" << n.as_string()->get() << "\"";
  else if (n.is_integer()) os << "the integer " << n.as_integer()->get();
  else if (n.is_floating_point()) os << "the number " << n.as_floating_point()->get();
  else if (n.is_boolean()) os << (n.as_boolean()->get() ? "true" : "false");
  else if (n.is_array()) os << "an array";
  else if (n.is_table()) os << "a table";
  else os << "a date or time";
  return os.str();
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Optimal string alignment distance (edits, with adjacent transpositions).
std::size_t edit_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[n][m];
}

std::string leaf(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

}  // namespace

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string w = lower(word);
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(w, lower(c));
    if (d < best_d) best_d = d, best = c;
  }
  // Close enough to be a slip of the keyboard: 1 edit in short words, 2 in
  // longer ones, 3 in long dotted keys.
  const std::size_t allowed = w.size() <= 4 ? 1 : w.size() <= 12 ? 2 : 3;
  if (!best.empty() && best_d <= allowed) return best;
  // The right key in the wrong table (drum.skin for neighbor.skin).
  std::string same_leaf;
  for (const auto& c : candidates)
    if (lower(leaf(c)) == lower(leaf(word))) {
      if (!same_leaf.empty()) return "";  // ambiguous
      same_leaf = c;
    }
  return same_leaf;
}

SceneFile::SceneFile(const std::string& path, const std::vector<std::string>& overrides) : path_(path) {
  try {
    table_ = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw SceneError(path, static_cast<long>(e.source().begin.line), "",
                     "not a valid TOML file: " + std::string(e.description()));
  }
  for (const std::string& ov : overrides) {
    const auto eq = ov.find('=');
    if (eq == std::string::npos || eq == 0)
      throw SceneError(path, "override --set '" + ov + "' is not of the form key=value");
    const std::string key = ov.substr(0, eq), value = ov.substr(eq + 1);
    toml::table holder;
    try {
      holder = toml::parse("v = " + value);
    } catch (const toml::parse_error&) {
      holder.insert_or_assign("v", value);  // a bare word: take it as a string
    }
    const auto parts = split_key(key);
    table_for(table_, parts, path, key + " (--set)")->insert_or_assign(parts.back(), *holder.get("v"));
    overridden_.insert(key);
  }
}

SceneFile SceneFile::from_text(const std::string& text, const std::string& name) {
  SceneFile f;
  f.path_ = name;
  try {
    f.table_ = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw SceneError(name, static_cast<long>(e.source().begin.line), "",
                     "not a valid TOML file: " + std::string(e.description()));
  }
  return f;
}

std::vector<std::string> SceneFile::read_keys() const { return {used_.begin(), used_.end()}; }

const toml::node* SceneFile::find(const std::string& key) const {
  const auto parts = split_key(key);
  const toml::table* t = &table_;
  for (std::size_t q = 0; q + 1 < parts.size(); ++q) {
    const auto* node = t->get(parts[q]);
    if (!node || !node->is_table()) return nullptr;
    t = node->as_table();
  }
  return t->get(parts.back());
}

bool SceneFile::has(const std::string& key) const { return find(key) != nullptr; }

long SceneFile::line_of(const std::string& key) const {
  if (overridden_.count(key) || defaulted_.count(key)) return 0;
  const auto* n = find(key);
  return n ? static_cast<long>(n->source().begin.line) : 0;
}

std::string SceneFile::origin(const std::string& key) const {
  if (overridden_.count(key)) return "--set";
  if (const long line = line_of(key)) return "line " + std::to_string(line);
  return "default";
}

std::string SceneFile::peek_text(const std::string& key) const {
  const auto* n = find(key);
  if (!n) missing(key);
  if (!n->is_string()) fail(key, "must be a string, got " + describe(*n));
  return n->as_string()->get();
}

void SceneFile::set_default(const std::string& key, toml::node&& value) {
  const auto parts = split_key(key);
  toml::table* t = table_for(table_, parts, path_, key);
  if (auto* v = value.as_floating_point()) t->insert_or_assign(parts.back(), v->get());
  else if (auto* i = value.as_integer()) t->insert_or_assign(parts.back(), i->get());
  else if (auto* s = value.as_string()) t->insert_or_assign(parts.back(), s->get());
  else if (auto* b = value.as_boolean()) t->insert_or_assign(parts.back(), b->get());
  defaulted_.insert(key);
}

template <class T>
void SceneFile::set_default_value(const std::string& key, T value) {
  toml::table holder;
  holder.insert("v", value);
  set_default(key, std::move(*holder.get("v")));
}

void SceneFile::fail(const std::string& key, const std::string& reason) const {
  throw SceneError(path_, line_of(key), overridden_.count(key) ? key + " (--set)" : key, reason);
}

void SceneFile::fail_at(long line, const std::string& key, const std::string& reason) const {
  if (line <= 0 || overridden_.count(key)) fail(key, reason);
  throw SceneError(path_, line, key, reason);
}

void SceneFile::missing(const std::string& key) const {
  // A value where the key needs a table ("drum = 3" for drum.length).
  const auto parts = split_key(key);
  std::string prefix;
  const toml::table* t = &table_;
  for (std::size_t q = 0; q + 1 < parts.size(); ++q) {
    prefix += (q ? "." : "") + parts[q];
    const auto* node = t->get(parts[q]);
    if (!node) break;
    if (!node->is_table()) fail(prefix, "must be a table ([" + prefix + "]), got " + describe(*node));
    t = node->as_table();
  }
  std::string where;
  if (parts.size() > 1) {
    const std::string table = key.substr(0, key.rfind('.'));
    const auto* node = find(table);
    where = node && node->source().begin.line > 0
                ? " (not in [" + table + "], line " + std::to_string(node->source().begin.line) + ")"
                : " (the file has no [" + table + "] table)";
  }
  fail(key, "missing (required)" + where);
}

void SceneFile::unknown(const std::string& key, const std::vector<std::string>& known) const {
  // A table name where the scene has a table of that name, but given a value
  // or an empty table: say what belongs in it.
  for (const auto& k : known)
    if (k.rfind(key + ".", 0) == 0) {
      const auto* n = find(key);
      if (n && !n->is_table()) fail(key, "must be a table ([" + key + "]), got " + describe(*n));
      return;  // an empty table of a known name is harmless
    }
  const std::string guess = did_you_mean(key, known);
  fail(key, guess.empty() ? "unknown key (not used by this scene kind)" : "unknown key; did you mean " + guess + "?");
}

double SceneFile::number(const std::string& key) {
  const auto* n = find(key);
  if (!n) missing(key);
  used_.insert(key);
  if (auto v = n->value<double>(); v && (n->is_floating_point() || n->is_integer())) {
    if (!std::isfinite(*v)) fail(key, "must be a finite number, got " + describe(*n));
    return *v;
  }
  fail(key, "must be a number, got " + describe(*n));
}

double SceneFile::number(const std::string& key, double fallback) {
  if (!find(key)) set_default_value(key, fallback);
  return number(key);
}

long SceneFile::integer(const std::string& key) {
  const auto* n = find(key);
  if (!n) missing(key);
  used_.insert(key);
  if (n->is_integer()) return static_cast<long>(n->as_integer()->get());
  fail(key, "must be an integer, got " + describe(*n));
}

long SceneFile::integer(const std::string& key, long fallback) {
  if (!find(key)) set_default_value(key, static_cast<int64_t>(fallback));
  return integer(key);
}

std::string SceneFile::text(const std::string& key) {
  const auto* n = find(key);
  if (!n) missing(key);
  used_.insert(key);
  if (n->is_string()) return n->as_string()->get();
  fail(key, "must be a string, got " + describe(*n));
}

std::string SceneFile::text(const std::string& key, const std::string& fallback) {
  if (!find(key)) set_default_value(key, fallback);
  return text(key);
}

std::string SceneFile::choice(const std::string& key, const std::vector<std::string>& allowed) {
  const std::string v = text(key);
  if (std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + ("\"" + a + "\"");
    const std::string guess = did_you_mean(v, allowed);
    fail(key, "unknown value \"" + v + "\"" + (guess.empty() ? "" : "; did you mean \"" + guess + "\"?") +
                  " (allowed: " + list + ")");
  }
  return v;
}

std::string SceneFile::choice(const std::string& key, const std::vector<std::string>& allowed,
                              const std::string& fallback) {
  if (!find(key)) set_default_value(key, fallback);
  return choice(key, allowed);
}

bool SceneFile::flag(const std::string& key, bool fallback) {
  if (!find(key)) set_default_value(key, fallback);
  used_.insert(key);
  const auto* n = find(key);
  if (n->is_boolean()) return n->as_boolean()->get();
  fail(key, "must be true or false, got " + describe(*n));
}

const toml::array& SceneFile::array(const std::string& key) {
  const auto* n = find(key);
  if (!n) missing(key);
  used_.insert(key);
  if (const auto* a = n->as_array()) return *a;
  fail(key, "must be an array, got " + describe(*n));
}

std::string number_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

double SceneFile::positive(const std::string& key, double v) const {
  if (!(v > 0.0)) fail(key, "must be > 0, got " + number_text(v));
  return v;
}

double SceneFile::non_negative(const std::string& key, double v) const {
  if (!(v >= 0.0)) fail(key, "must be >= 0, got " + number_text(v));
  return v;
}

std::vector<std::string> SceneFile::keys_in_order() const {
  std::vector<std::string> keys;
  collect_keys(table_, "", keys);
  // File order; --set overrides (line 0) first: they were typed last.
  std::stable_sort(keys.begin(), keys.end(),
                   [&](const std::string& a, const std::string& b) { return line_of(a) < line_of(b); });
  return keys;
}

void SceneFile::reject_keys_outside(const std::vector<std::string>& known) const {
  const std::set<std::string> k(known.begin(), known.end());
  for (const auto& key : keys_in_order())
    if (!k.count(key)) unknown(key, known);
}

void SceneFile::reject_unknown_keys() const {
  const std::vector<std::string> known(used_.begin(), used_.end());
  for (const auto& key : keys_in_order())
    if (!used_.count(key)) unknown(key, known);
}

std::string SceneFile::resolved_toml() const {
  std::ostringstream os;
  os << toml::toml_formatter{table_};
  return os.str();
}

std::string SceneFile::resolved_json() const {
  std::ostringstream os;
  os << toml::json_formatter{table_};
  return os.str();
}

}  // namespace granular
