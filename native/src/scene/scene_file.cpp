#include "scene/scene_file.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace granular {

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

void collect_keys(const toml::table& t, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& [k, v] : t) {
    const std::string full = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (const auto* sub = v.as_table())
      collect_keys(*sub, full, out);
    else
      out.push_back(full);
  }
}

}  // namespace

SceneFile::SceneFile(const std::string& path, const std::vector<std::string>& overrides) : path_(path) {
  try {
    table_ = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    std::ostringstream os;
    os << "not a valid TOML file: " << e.description() << " (line " << e.source().begin.line << ")";
    throw SceneError(path, os.str());
  }
  for (const std::string& ov : overrides) {
    const auto eq = ov.find('=');
    if (eq == std::string::npos || eq == 0)
      throw SceneError(path, "override '" + ov + "' is not of the form key=value");
    const std::string key = ov.substr(0, eq), value = ov.substr(eq + 1);
    toml::table holder;
    try {
      holder = toml::parse("v = " + value);
    } catch (const toml::parse_error&) {
      holder.insert_or_assign("v", value);  // a bare word: take it as a string
    }
    const auto parts = split_key(key);
    table_for(table_, parts, path, key)->insert_or_assign(parts.back(), *holder.get("v"));
  }
}

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

std::string SceneFile::peek_text(const std::string& key) const {
  const auto* n = find(key);
  if (!n) fail(key, "missing (required)");
  if (!n->is_string()) fail(key, "must be a string");
  return n->as_string()->get();
}

void SceneFile::set_default(const std::string& key, toml::node&& value) {
  const auto parts = split_key(key);
  toml::table* t = table_for(table_, parts, path_, key);
  if (auto* v = value.as_floating_point()) t->insert_or_assign(parts.back(), v->get());
  else if (auto* i = value.as_integer()) t->insert_or_assign(parts.back(), i->get());
  else if (auto* s = value.as_string()) t->insert_or_assign(parts.back(), s->get());
  else if (auto* b = value.as_boolean()) t->insert_or_assign(parts.back(), b->get());
}

template <class T>
void SceneFile::set_default_value(const std::string& key, T value) {
  toml::table holder;
  holder.insert("v", value);
  set_default(key, std::move(*holder.get("v")));
}

void SceneFile::fail(const std::string& key, const std::string& reason) const { throw SceneError(path_, key, reason); }

double SceneFile::number(const std::string& key) {
  const auto* n = find(key);
  if (!n) fail(key, "missing (required)");
  used_.insert(key);
  if (auto v = n->value<double>()) {
    if (!std::isfinite(*v)) fail(key, "must be a finite number");
    return *v;
  }
  fail(key, "must be a number");
}

double SceneFile::number(const std::string& key, double fallback) {
  if (!find(key)) set_default_value(key, fallback);
  return number(key);
}

long SceneFile::integer(const std::string& key) {
  const auto* n = find(key);
  if (!n) fail(key, "missing (required)");
  used_.insert(key);
  if (n->is_integer()) return static_cast<long>(n->as_integer()->get());
  fail(key, "must be an integer");
}

long SceneFile::integer(const std::string& key, long fallback) {
  if (!find(key)) set_default_value(key, static_cast<int64_t>(fallback));
  return integer(key);
}

std::string SceneFile::text(const std::string& key) {
  const auto* n = find(key);
  if (!n) fail(key, "missing (required)");
  used_.insert(key);
  if (n->is_string()) return n->as_string()->get();
  fail(key, "must be a string");
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
    fail(key, "is \"" + v + "\"; allowed: " + list);
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
  fail(key, "must be true or false");
}

double SceneFile::positive(const std::string& key, double v) const {
  if (!(v > 0.0)) fail(key, "must be > 0 (got " + std::to_string(v) + ")");
  return v;
}

double SceneFile::non_negative(const std::string& key, double v) const {
  if (!(v >= 0.0)) fail(key, "must be >= 0 (got " + std::to_string(v) + ")");
  return v;
}

void SceneFile::reject_unknown_keys() const {
  std::vector<std::string> keys;
  collect_keys(table_, "", keys);
  for (const auto& k : keys)
    if (!used_.count(k)) fail(k, "unknown key (misspelt, or not used by this scene kind)");
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
