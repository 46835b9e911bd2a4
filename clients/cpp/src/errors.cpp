#include "nfex/errors.hpp"

#include <utility>

namespace nfex {

namespace {

std::string text_of(const nlohmann::json& doc, const char* key) {
    auto it = doc.find(key);
    return it != doc.end() && it->is_string() ? it->get<std::string>() : std::string();
}

std::string reason_phrase(int status) {
    switch (status) {
        case 400: return "Bad request";
        case 401: return "Unauthorized";
        case 403: return "Forbidden";
        case 404: return "Not found";
        case 502: return "Bad gateway";
        case 503: return "Service unavailable";
        case 504: return "Gateway timeout";
        default: return "HTTP " + std::to_string(status);
    }
}

}  // namespace

TransportError::TransportError(Kind kind, const std::string& message, int attempts)
    : Error(message), kind_(kind), attempts_(attempts) {}

ProblemError::ProblemError(int status, nlohmann::json problem)
    : Error(std::to_string(status) + " " + text_of(problem, "title") + ": " + text_of(problem, "detail")),
      status_(status),
      problem_(std::move(problem)),
      type_(text_of(problem_, "type")),
      title_(text_of(problem_, "title")),
      detail_(text_of(problem_, "detail")) {}

std::string ProblemError::slug() const {
    auto slash = type_.rfind('/');
    return slash == std::string::npos ? type_ : type_.substr(slash + 1);
}

long long PreconditionFailed::current_version() const {
    auto it = problem().find("current_version");
    return it != problem().end() && it->is_number_integer() ? it->get<long long>() : -1;
}

std::vector<std::string> Unprocessable::allowed() const {
    std::vector<std::string> out;
    auto it = problem().find("allowed");
    if (it != problem().end() && it->is_array())
        for (const auto& v : *it)
            if (v.is_string()) out.push_back(v.get<std::string>());
    return out;
}

nlohmann::json Unprocessable::violations() const {
    auto it = problem().find("violations");
    return it != problem().end() ? *it : nlohmann::json::array();
}

std::string ServiceUnavailable::limit() const { return text_of(problem(), "limit"); }

void throw_problem(int status, const std::string& body) {
    nlohmann::json doc = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
    if (!doc.is_object() || !doc.contains("title"))
        doc = {{"title", reason_phrase(status)}, {"detail", body.substr(0, 500)}, {"status", status}};
    switch (status) {
        case 400: throw BadRequest(status, std::move(doc));
        case 401: throw Unauthorized(status, std::move(doc));
        case 403: throw Forbidden(status, std::move(doc));
        case 404: throw NotFound(status, std::move(doc));
        case 406: throw NotAcceptable(status, std::move(doc));
        case 409: throw Conflict(status, std::move(doc));
        case 412: throw PreconditionFailed(status, std::move(doc));
        case 413: throw PayloadTooLarge(status, std::move(doc));
        case 415: throw UnsupportedMediaType(status, std::move(doc));
        case 422: throw Unprocessable(status, std::move(doc));
        case 429: throw TooManyRequests(status, std::move(doc));
        case 501: throw NotImplemented(status, std::move(doc));
        case 503: throw ServiceUnavailable(status, std::move(doc));
        default:
            if (status >= 500) throw ServerError(status, std::move(doc));
            throw ProblemError(status, std::move(doc));
    }
}

}  // namespace nfex
