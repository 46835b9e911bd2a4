// nFEX C++ client: errors. One base (nfex::Error); the service's RFC 9457 problem+json answers become
// ProblemError subclasses by HTTP status, each carrying the problem's type, title, detail and status.
#pragma once

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace nfex {

/// Base of every error the client throws.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// No HTTP answer came back: the service could not be reached, or did not answer in time.
class TransportError : public Error {
public:
    enum class Kind { connect, timeout, other };
    TransportError(Kind kind, const std::string& message, int attempts);
    Kind kind() const noexcept { return kind_; }
    /// How many times the request was sent (retries included).
    int attempts() const noexcept { return attempts_; }

private:
    Kind kind_;
    int attempts_;
};

/// An answer the client cannot read (not the JSON the API documents).
class ProtocolError : public Error {
public:
    using Error::Error;
};

/// make_feature2d cannot build what a selection names (unknown constructor or argument, or an argument
/// this OpenCV build lacks).
class ExtractorError : public Error {
public:
    using Error::Error;
};

/// An RFC 9457 problem+json answer (status >= 400).
class ProblemError : public Error {
public:
    ProblemError(int status, nlohmann::json problem);
    int status() const noexcept { return status_; }
    /// The problem type URI, e.g. https://w3id.org/nfex/problems/unknown-name.
    const std::string& type() const noexcept { return type_; }
    const std::string& title() const noexcept { return title_; }
    const std::string& detail() const noexcept { return detail_; }
    /// The last segment of type(), e.g. "unknown-name".
    std::string slug() const;
    /// The whole problem document (extra members such as allowed, violations, limit).
    const nlohmann::json& problem() const noexcept { return problem_; }

private:
    int status_;
    nlohmann::json problem_;
    std::string type_, title_, detail_;
};

class BadRequest : public ProblemError { using ProblemError::ProblemError; };            // 400
class Unauthorized : public ProblemError { using ProblemError::ProblemError; };          // 401
class Forbidden : public ProblemError { using ProblemError::ProblemError; };             // 403
class NotFound : public ProblemError { using ProblemError::ProblemError; };              // 404
class NotAcceptable : public ProblemError { using ProblemError::ProblemError; };         // 406
class Conflict : public ProblemError { using ProblemError::ProblemError; };              // 409
class PayloadTooLarge : public ProblemError { using ProblemError::ProblemError; };       // 413
class UnsupportedMediaType : public ProblemError { using ProblemError::ProblemError; };  // 415
class TooManyRequests : public ProblemError { using ProblemError::ProblemError; };       // 429
class NotImplemented : public ProblemError { using ProblemError::ProblemError; };        // 501
class ServerError : public ProblemError { using ProblemError::ProblemError; };           // other 5xx

/// 412: If-Match named a graph version that is no longer the head.
class PreconditionFailed : public Conflict {
public:
    using Conflict::Conflict;
    /// The head version the service reported, or -1.
    long long current_version() const;
};

/// 422: unknown names (allowed() lists what the graph knows), SHACL violations, no candidate left.
class Unprocessable : public ProblemError {
public:
    using ProblemError::ProblemError;
    std::vector<std::string> allowed() const;
    nlohmann::json violations() const;
};

/// 503: the store is unavailable, or a SPARQL query hit a limit (limit(): "time", "result-size", "concurrency").
class ServiceUnavailable : public ProblemError {
public:
    using ProblemError::ProblemError;
    std::string limit() const;
};

/// Throws the ProblemError subclass for an error answer; a body that is not a problem document becomes
/// one with the reason phrase as title and the start of the body as detail.
[[noreturn]] void throw_problem(int status, const std::string& body);

}  // namespace nfex
