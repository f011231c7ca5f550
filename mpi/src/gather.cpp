// ensemble_for's items from every rank to the root (gather.hpp): packed per rank, sent in pieces of 1 GiB,
// placed by index with a check that each index comes back exactly once.
#include "gather.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace nonholo::detail {
namespace {

// MPI counts are int: larger buffers go in pieces of 1 GiB.
constexpr std::uint64_t kPiece = std::uint64_t{1} << 30;
constexpr int kTag = 1;

// A rank's jobs as one buffer: per job its index, the sizes of data and error, then both.
std::string pack(const std::vector<DoneJob>& done) {
  std::string buffer;
  for (const DoneJob& d : done) {
    const std::uint64_t head[3] = {static_cast<std::uint64_t>(d.index), d.item.data.size(), d.item.error.size()};
    buffer.append(reinterpret_cast<const char*>(head), sizeof head);
    buffer += d.item.data;
    buffer += d.item.error;
  }
  return buffer;
}

// Places one job's item at its index; the root's check that no index comes twice or never.
void place(std::vector<EnsembleItem>& items, std::vector<char>& seen, long index, EnsembleItem&& item) {
  if (index < 0 || index >= static_cast<long>(items.size()) || seen[static_cast<std::size_t>(index)])
    throw std::logic_error("ensemble_for: job " + std::to_string(index) + " came back twice or out of range");
  seen[static_cast<std::size_t>(index)] = 1;
  items[static_cast<std::size_t>(index)] = std::move(item);
}

void unpack(const std::string& buffer, std::vector<EnsembleItem>& items, std::vector<char>& seen) {
  std::size_t at = 0;
  while (at < buffer.size()) {
    std::uint64_t head[3];
    if (buffer.size() - at < sizeof head) throw std::logic_error("ensemble_for: truncated results");
    std::memcpy(head, buffer.data() + at, sizeof head);
    at += sizeof head;
    if (buffer.size() - at < head[1] + head[2]) throw std::logic_error("ensemble_for: truncated results");
    EnsembleItem item{buffer.substr(at, head[1]), buffer.substr(at + head[1], head[2])};
    at += head[1] + head[2];
    place(items, seen, static_cast<long>(head[0]), std::move(item));
  }
}

void send(MPI_Comm comm, int root, const std::string& buffer) {
  std::uint64_t size = buffer.size();
  MPI_Send(&size, 1, MPI_UINT64_T, root, kTag, comm);
  for (std::uint64_t at = 0; at < size; at += kPiece)
    MPI_Send(buffer.data() + at, static_cast<int>(std::min(kPiece, size - at)), MPI_BYTE, root, kTag, comm);
}

std::string receive(MPI_Comm comm, int from) {
  std::uint64_t size = 0;
  MPI_Recv(&size, 1, MPI_UINT64_T, from, kTag, comm, MPI_STATUS_IGNORE);
  std::string buffer(size, '\0');
  for (std::uint64_t at = 0; at < size; at += kPiece)
    MPI_Recv(buffer.data() + at, static_cast<int>(std::min(kPiece, size - at)), MPI_BYTE, from, kTag, comm,
             MPI_STATUS_IGNORE);
  return buffer;
}

}  // namespace

std::vector<EnsembleItem> gather_items(MPI_Comm comm, int root, long count, std::vector<DoneJob> done) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (rank != root) {
    send(comm, root, pack(done));
    return {};
  }
  std::vector<EnsembleItem> items(static_cast<std::size_t>(count));
  std::vector<char> seen(items.size(), 0);
  for (DoneJob& d : done) place(items, seen, d.index, std::move(d.item));
  // Rank by rank: the root's memory holds the whole table anyway.
  for (int r = 0; r < size; ++r)
    if (r != root) unpack(receive(comm, r), items, seen);
  if (std::find(seen.begin(), seen.end(), 0) != seen.end())
    throw std::logic_error("ensemble_for: a job never came back");
  return items;
}

}  // namespace nonholo::detail
