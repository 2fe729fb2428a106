// The closed list of error types of pbgi. Each carries enough context to
// act on (file, offset, page id, prim path, request id) in its message.
#pragma once

#include <stdexcept>
#include <string>

namespace pbgi {

// Base of all pbgi errors.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A file or socket operation failed (names the path and errno text).
struct IoError : Error { using Error::Error; };
// Stored data failed a check: bad magic, checksum, size (names file, offset,
// expected and found values).
struct CorruptionError : Error { using Error::Error; };
// Stored data has a format version this build does not read.
struct VersionError : Error { using Error::Error; };
// A caller passed something invalid (names the field or option at fault).
struct InvalidArgument : Error { using Error::Error; };
// What a caller asked to create exists already (a page set directory that
// another build published first: content-addressed, so it is the same).
struct AlreadyExists : InvalidArgument { using InvalidArgument::InvalidArgument; };
// A path lies outside what the caller may use: a scene, or a file a scene
// names, outside the daemon's scene roots (names what used it, never where
// the path leads: that would disclose the filesystem outside).
struct PermissionDenied : Error { using Error::Error; };
// A named thing (scene, camera, page set) does not exist.
struct NotFound : Error { using Error::Error; };
// Input scene could not be read (names the file and prim).
struct SceneError : Error { using Error::Error; };
// Work was cancelled by the caller (deadline or disconnect).
struct Cancelled : Error { using Error::Error; };
// Work would pass a limit set by whoever runs it, not by the request
// (pbgid's limits.max_surfels, staging_quota): names the limit and its value.
struct ResourceExhausted : Error { using Error::Error; };

}  // namespace pbgi
