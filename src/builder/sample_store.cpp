#include "builder/sample_store.h"

#include <sqlite3.h>
#include <zstd.h>

#include <cstring>

namespace cadinterp::builder {

namespace {

// Samples are compressed: meshes are most of a store's bytes, and a store holds every sample of
// a build (hundreds of meshes). zstd level 1: its cost is negligible next to a host call.
std::vector<std::uint8_t> compress(const std::vector<std::uint8_t>& raw) {
  std::vector<std::uint8_t> out(8 + ZSTD_compressBound(raw.size()));
  const std::uint64_t n = raw.size();
  std::memcpy(out.data(), &n, 8);
  const std::size_t z = ZSTD_compress(out.data() + 8, out.size() - 8, raw.data(), raw.size(), 1);
  if (ZSTD_isError(z)) throw StoreError(StoreError::Kind::Io, "sample store: compression failed");
  out.resize(8 + z);
  return out;
}

bool decompress(const void* data, std::size_t size, std::vector<std::uint8_t>& raw) {
  if (size < 8) return false;
  std::uint64_t n = 0;
  std::memcpy(&n, data, 8);
  if (n > (std::uint64_t(1) << 36)) return false;
  raw.resize(static_cast<std::size_t>(n));
  const std::size_t got =
      ZSTD_decompress(raw.data(), raw.size(), static_cast<const std::uint8_t*>(data) + 8, size - 8);
  return !ZSTD_isError(got) && got == n;
}

}  // namespace

void SampleStore::check(int rc, const char* what) {
  if (rc == SQLITE_OK || rc == SQLITE_DONE || rc == SQLITE_ROW) return;
  throw StoreError(StoreError::Kind::Io, std::string("sample store: ") + what + ": " +
                                             (db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc)));
}

SampleStore::SampleStore(const std::string& path, const std::string& fingerprint) {
  try {
    check(sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr),
          "open");
    sqlite3_busy_timeout(db_, 5000);
    // WAL + synchronous=NORMAL: a committed transaction survives the process being killed (the
    // WAL is written before commit returns); only power loss could drop the last commits.
    check(sqlite3_exec(
              db_,
              "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"
              "CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);"
              "CREATE TABLE IF NOT EXISTS samples(x BLOB PRIMARY KEY, sample BLOB NOT NULL);",
              nullptr, nullptr, nullptr),
          "create tables");
    sqlite3_stmt* st = nullptr;
    check(
        sqlite3_prepare_v2(db_, "SELECT value FROM meta WHERE key='fingerprint'", -1, &st, nullptr),
        "read fingerprint");
    const int rc = sqlite3_step(st);
    std::string stored;
    if (rc == SQLITE_ROW) stored = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    check(rc, "read fingerprint");
    if (rc == SQLITE_DONE) {
      check(sqlite3_prepare_v2(db_, "INSERT INTO meta(key, value) VALUES('fingerprint', ?)", -1,
                               &st, nullptr),
            "write fingerprint");
      sqlite3_bind_text(st, 1, fingerprint.c_str(), -1, SQLITE_TRANSIENT);
      const int w = sqlite3_step(st);
      sqlite3_finalize(st);
      check(w, "write fingerprint");
    } else if (stored != fingerprint) {
      throw StoreError(StoreError::Kind::Mismatch, "sample store '" + path +
                                                       "' holds samples of another model or box (" +
                                                       stored + "); use another store file");
    }
    check(sqlite3_prepare_v2(db_, "SELECT sample FROM samples WHERE x = ?", -1, &get_, nullptr),
          "prepare");
    check(sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO samples(x, sample) VALUES(?, ?)", -1,
                             &put_, nullptr),
          "prepare");
  } catch (const StoreError& e) {
    sqlite3_finalize(get_);
    sqlite3_finalize(put_);
    sqlite3_close(db_);
    // SQLite's messages do not name the file; a user with several stores needs to know which.
    if (e.kind == StoreError::Kind::Io)
      throw StoreError(e.kind, std::string(e.what()) + " (store '" + path + "')");
    throw;
  } catch (...) {
    sqlite3_finalize(get_);
    sqlite3_finalize(put_);
    sqlite3_close(db_);
    throw;
  }
}

SampleStore::~SampleStore() {
  sqlite3_finalize(get_);
  sqlite3_finalize(put_);
  sqlite3_close(db_);
}

bool SampleStore::get(const std::vector<double>& x, Sample& out) {
  sqlite3_reset(get_);
  sqlite3_bind_blob(get_, 1, x.data(), static_cast<int>(x.size() * sizeof(double)), SQLITE_STATIC);
  const int rc = sqlite3_step(get_);
  if (rc == SQLITE_DONE) return false;
  check(rc, "read sample");
  std::vector<std::uint8_t> raw;
  const bool ok = decompress(sqlite3_column_blob(get_, 0),
                             static_cast<std::size_t>(sqlite3_column_bytes(get_, 0)), raw);
  sqlite3_reset(get_);
  if (!ok) return false;
  try {
    out = deserialize(raw.data(), raw.size());
  } catch (const std::runtime_error&) {
    return false;
  }
  return true;
}

void SampleStore::put(const std::vector<double>& x, const Sample& s) {
  const std::vector<std::uint8_t> z = compress(serialize(s));
  sqlite3_reset(put_);
  sqlite3_bind_blob(put_, 1, x.data(), static_cast<int>(x.size() * sizeof(double)), SQLITE_STATIC);
  sqlite3_bind_blob64(put_, 2, z.data(), z.size(), SQLITE_STATIC);
  const int rc = sqlite3_step(put_);
  sqlite3_reset(put_);
  check(rc, "write sample");
}

std::int64_t SampleStore::size() {
  sqlite3_stmt* st = nullptr;
  check(sqlite3_prepare_v2(db_, "SELECT COUNT(*) FROM samples", -1, &st, nullptr), "count");
  const int rc = sqlite3_step(st);
  const std::int64_t n = rc == SQLITE_ROW ? sqlite3_column_int64(st, 0) : 0;
  sqlite3_finalize(st);
  check(rc, "count");
  return n;
}

std::vector<std::vector<double>> SampleStore::keys() {
  sqlite3_stmt* st = nullptr;
  check(sqlite3_prepare_v2(db_, "SELECT x FROM samples ORDER BY x", -1, &st, nullptr), "keys");
  std::vector<std::vector<double>> out;
  int rc;
  while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
    const auto n = static_cast<std::size_t>(sqlite3_column_bytes(st, 0)) / sizeof(double);
    std::vector<double> x(n);
    if (n) std::memcpy(x.data(), sqlite3_column_blob(st, 0), n * sizeof(double));
    out.push_back(std::move(x));
  }
  sqlite3_finalize(st);
  check(rc, "keys");
  return out;
}

}  // namespace cadinterp::builder
