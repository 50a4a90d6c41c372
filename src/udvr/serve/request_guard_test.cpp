// Which requests udvr serve takes (issue 34, items 3 and 9): Host, Origin, Sec-Fetch-Site and the
// body's announced length and encodings, decided before any of the body is read.
#include "udvr/serve/request_guard.h"

#include <gtest/gtest.h>

namespace udvr::serve {
namespace {

TEST(RequestGuard, HostNames) {
    EXPECT_EQ(hostNameOf("LocalHost:8080"), "localhost");
    EXPECT_EQ(hostNameOf("[::1]:8080"), "::1");
    EXPECT_EQ(hostNameOf("127.0.0.1"), "127.0.0.1");
    EXPECT_EQ(hostNameOf("a b"), "");
    EXPECT_EQ(hostNameOf("x:80:80"), "");
    EXPECT_EQ(hostNameOf("[::1"), "");
    for (const char* name : {"localhost", "app.localhost", "127.0.0.1", "127.255.0.9", "::1"})
        EXPECT_TRUE(isLoopbackName(name)) << name;
    for (const char* name : {"evil.example", "127.0.0.1.evil.example", "localhost.evil.example",
                             "10.0.0.1", "127.0.0", "127.0.0.256", "0.0.0.0", ""})
        EXPECT_FALSE(isLoopbackName(name)) << name;
}

// Before: any web page could POST to the server, and DNS rebinding (Host: evil.example) worked.
TEST(RequestGuard, OnlyLoopbackHostsAndTheServersOwnOrigin) {
    const std::vector<std::string> none;
    EXPECT_FALSE(refusedOrigin("127.0.0.1:8080", "", "", none));
    EXPECT_FALSE(refusedOrigin("127.0.0.1:8080", "http://127.0.0.1:8080", "same-origin", none));
    EXPECT_FALSE(refusedOrigin("localhost:8080", "", "none", none));
    EXPECT_TRUE(refusedOrigin("evil.example:8080", "", "", none));
    EXPECT_TRUE(refusedOrigin("", "", "", none));
    EXPECT_TRUE(refusedOrigin("127.0.0.1:8080", "http://evil.example", "", none));
    EXPECT_TRUE(refusedOrigin("127.0.0.1:8080", "null", "", none));
    EXPECT_TRUE(refusedOrigin("127.0.0.1:8080", "http://127.0.0.1:8081", "", none));
    EXPECT_TRUE(refusedOrigin("127.0.0.1:8080", "", "cross-site", none));
    EXPECT_TRUE(refusedOrigin("127.0.0.1:8080", "", "same-site", none));
    // A reverse proxy's name, with TLS in front.
    const std::vector<std::string> proxy{"viewer.example"};
    EXPECT_FALSE(refusedOrigin("viewer.example", "https://viewer.example", "same-origin", proxy));
    EXPECT_TRUE(refusedOrigin("other.example", "", "", proxy));
    EXPECT_FALSE(refusedOrigin("anything.example", "", "", {"*"}));
    EXPECT_TRUE(refusedOrigin("anything.example", "http://else.example", "", {"*"}));
}

TEST(RequestGuard, BodiesAreRefusedBeforeReading) {
    const std::size_t limit = 1 << 20;
    const auto status = [&](BodyHeaders h) {
        const auto r = refusedBody(h, limit);
        return r ? r->first : 0;
    };
    EXPECT_EQ(status({"POST", "100", "", "", "application/json"}), 0);
    EXPECT_EQ(status({"POST", "", "chunked", "", ""}), 0);  // read up to the limit
    EXPECT_EQ(status({"GET", "", "", "", ""}), 0);
    EXPECT_EQ(status({"POST", "1099511627776", "", "", ""}), 413);
    EXPECT_EQ(status({"POST", "99999999999999999999999", "", "", ""}), 400);
    EXPECT_EQ(status({"POST", "-1", "", "", ""}), 400);
    EXPECT_EQ(status({"POST", "", "", "", ""}), 411);
    EXPECT_EQ(status({"POST", "10", "chunked", "", ""}), 400);
    EXPECT_EQ(status({"POST", "", "gzip, chunked", "", ""}), 501);
    EXPECT_EQ(status({"POST", "10", "", "gzip", ""}), 415);
    EXPECT_EQ(status({"POST", "10", "", "", "multipart/form-data; boundary=x"}), 415);
    EXPECT_EQ(status({"GET", "10", "", "", ""}), 400);
    EXPECT_EQ(status({"GET", "", "chunked", "", ""}), 400);
}

}  // namespace
}  // namespace udvr::serve
