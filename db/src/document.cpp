#include "arscout/db/document.h"

#include <ctime>

namespace arscout::db {
namespace {

std::string rfc3339_utc(std::int64_t us) {
  std::time_t secs = static_cast<std::time_t>(us / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[40];
  std::size_t n = std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  std::snprintf(buf + n, sizeof buf - n, ".%06lldZ",
                static_cast<long long>(us % 1000000));
  return buf;
}

}  // namespace

const char* to_string(OpType op) {
  switch (op) {
    case OpType::kPut:
      return "put";
    case OpType::kPatch:
      return "patch";
    case OpType::kDelete:
      return "delete";
  }
  return "put";
}

Json to_json(const Document& doc) {
  return Json{{"path", doc.path},
              {"kind", doc.kind},
              {"attrs", doc.attrs},
              {"blobs", doc.blobs},
              {"version", doc.version},
              {"seq", doc.seq},
              {"created", rfc3339_utc(doc.created_us)},
              {"updated", rfc3339_utc(doc.updated_us)},
              {"author", doc.author}};
}

Json to_json(const Change& change) {
  return Json{{"seq", change.seq},
              {"path", change.path},
              {"op", to_string(change.op)},
              {"version", change.version},
              {"kind", change.kind},
              {"author", change.author},
              {"time", rfc3339_utc(change.time_us)}};
}

WriteOp WriteOp::put(std::string path, std::string kind, Json attrs,
                     std::optional<std::int64_t> expected) {
  WriteOp op;
  op.type = OpType::kPut;
  op.path = std::move(path);
  op.kind = std::move(kind);
  op.attrs = std::move(attrs);
  op.expected_version = expected;
  return op;
}

WriteOp WriteOp::patch(std::string path, Json merge_patch,
                       std::optional<std::int64_t> expected) {
  WriteOp op;
  op.type = OpType::kPatch;
  op.path = std::move(path);
  op.attrs = std::move(merge_patch);
  op.expected_version = expected;
  return op;
}

WriteOp WriteOp::remove(std::string path,
                        std::optional<std::int64_t> expected) {
  WriteOp op;
  op.type = OpType::kDelete;
  op.path = std::move(path);
  op.expected_version = expected;
  return op;
}

}  // namespace arscout::db
