#include "transport.hpp"

#include "nfex/errors.hpp"

#include <algorithm>
#include <memory>
#include <mutex>
#include <thread>

namespace nfex::detail {

namespace {

std::size_t append(char* data, std::size_t size, std::size_t count, void* out) {
    static_cast<std::string*>(out)->append(data, size * count);
    return size * count;
}

struct SlistDeleter {
    void operator()(curl_slist* list) const { curl_slist_free_all(list); }
};
struct MimeDeleter {
    void operator()(curl_mime* mime) const { curl_mime_free(mime); }
};

/// A 503 that is a query's own time or size limit: sending the same query again cannot help.
bool query_over_its_limit(const std::string& body) {
    auto doc = nlohmann::json::parse(body, nullptr, false);
    if (!doc.is_object()) return false;
    std::string limit = doc.value("limit", "");
    return limit == "time" || limit == "result-size";
}

bool retry_answer(const Request& request, const Response& r) {
    if (r.status == 429) return true;  // refused before anything happened
    if (!request.idempotent) return false;
    if (r.status == 502 || r.status == 504) return true;
    return r.status == 503 && !query_over_its_limit(r.body);
}

}  // namespace

struct Transport::Attempt {
    CURLcode code = CURLE_OK;
    std::string error;
    Response response;
};

Transport::Transport(std::string url, std::string token, Options options)
    : url_(std::move(url)), token_(std::move(token)), options_(options) {
    static std::once_flag global;
    std::call_once(global, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
    while (!url_.empty() && url_.back() == '/') url_.pop_back();
    curl_ = curl_easy_init();
    if (curl_ == nullptr) throw Error("libcurl could not create a handle");
}

Transport::~Transport() { curl_easy_cleanup(curl_); }

Transport::Attempt Transport::perform(const Request& request) {
    std::lock_guard<std::mutex> lock(mutex_);
    Attempt a;
    char error[CURL_ERROR_SIZE] = {0};
    curl_easy_reset(curl_);  // keeps the live connections
    std::string url = url_ + request.path;
    curl_easy_setopt(curl_, CURLOPT_URL, url.c_str());
    curl_easy_setopt(curl_, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(curl_, CURLOPT_ERRORBUFFER, error);
    curl_easy_setopt(curl_, CURLOPT_CONNECTTIMEOUT_MS, static_cast<long>(options_.connect_timeout.count()));
    curl_easy_setopt(curl_, CURLOPT_TIMEOUT_MS, static_cast<long>(options_.timeout.count()));
    curl_easy_setopt(curl_, CURLOPT_USERAGENT, "nfex-cpp/0.1");
    curl_easy_setopt(curl_, CURLOPT_WRITEFUNCTION, append);
    curl_easy_setopt(curl_, CURLOPT_WRITEDATA, &a.response.body);

    curl_slist* raw = nullptr;
    raw = curl_slist_append(raw, ("Accept: " + request.accept).c_str());
    raw = curl_slist_append(raw, "Expect:");  // no 100-continue round trip before a frame
    if (!token_.empty()) raw = curl_slist_append(raw, ("Authorization: Bearer " + token_).c_str());
    if (!request.content_type.empty()) raw = curl_slist_append(raw, ("Content-Type: " + request.content_type).c_str());
    std::unique_ptr<curl_slist, SlistDeleter> headers(raw);
    curl_easy_setopt(curl_, CURLOPT_HTTPHEADER, headers.get());

    std::unique_ptr<curl_mime, MimeDeleter> mime;
    if (!request.parts.empty()) {
        mime.reset(curl_mime_init(curl_));
        for (const Part& p : request.parts) {
            curl_mimepart* part = curl_mime_addpart(mime.get());
            curl_mime_name(part, p.name.c_str());
            curl_mime_data(part, p.data.data(), p.data.size());
            if (!p.filename.empty()) curl_mime_filename(part, p.filename.c_str());
            if (!p.content_type.empty()) curl_mime_type(part, p.content_type.c_str());
        }
        curl_easy_setopt(curl_, CURLOPT_MIMEPOST, mime.get());
    } else if (request.method == "POST" || request.method == "PUT") {
        curl_easy_setopt(curl_, CURLOPT_POSTFIELDS, request.body.data());
        curl_easy_setopt(curl_, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(request.body.size()));
    }
    if (request.method != "GET" && request.method != "POST") curl_easy_setopt(curl_, CURLOPT_CUSTOMREQUEST, request.method.c_str());

    a.code = curl_easy_perform(curl_);
    if (a.code == CURLE_OK) {
        long status = 0;
        curl_easy_getinfo(curl_, CURLINFO_RESPONSE_CODE, &status);
        a.response.status = static_cast<int>(status);
    } else {
        a.error = error[0] != '\0' ? error : curl_easy_strerror(a.code);
    }
    return a;
}

Response Transport::send(const Request& request) {
    for (int attempt = 1;; ++attempt) {
        Attempt a = perform(request);
        bool last = attempt > options_.retries;
        if (a.code == CURLE_OK) {
            if (last || !retry_answer(request, a.response)) return std::move(a.response);
        } else {
            using Kind = TransportError::Kind;
            bool refused = a.code == CURLE_COULDNT_CONNECT || a.code == CURLE_COULDNT_RESOLVE_HOST ||
                           a.code == CURLE_COULDNT_RESOLVE_PROXY;  // nothing reached the service
            Kind kind = refused ? Kind::connect : a.code == CURLE_OPERATION_TIMEDOUT ? Kind::timeout : Kind::other;
            if (last || !(kind == Kind::connect || request.idempotent))
                throw TransportError(kind, request.method + " " + url_ + request.path + ": " + a.error + " (" +
                                               std::to_string(attempt) + (attempt == 1 ? " attempt)" : " attempts)"),
                                     attempt);
        }
        auto wait = options_.backoff * (1LL << std::min(attempt - 1, 20));
        std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(wait, options_.max_backoff));
    }
}

nlohmann::json Transport::call(const Request& request) {
    Response r = send(request);
    if (r.status >= 400) throw_problem(r.status, r.body);
    if (r.status == 204 || r.body.empty()) return nullptr;
    auto doc = nlohmann::json::parse(r.body, nullptr, false);
    if (doc.is_discarded())
        throw ProtocolError(request.method + " " + request.path + " answered " + std::to_string(r.status) +
                            " with a body that is not JSON: " + r.body.substr(0, 200));
    return doc;
}

}  // namespace nfex::detail
