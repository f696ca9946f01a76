// A test suite that shares one real riskplan-server (started once, on port 0)
// between its tests, each test with its own client.
#ifndef RISKPLAN_TESTS_INTEGRATION_SHARED_SERVER_TEST_H_
#define RISKPLAN_TESTS_INTEGRATION_SHARED_SERVER_TEST_H_

#include <memory>
#include <string>
#include <vector>

#include "client/client.h"
#include "gtest/gtest.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {

// class MyTest : public SharedServerTest<MyTest> {...};  The server gets
// Suite::ServerFlags() (none unless the suite declares its own).
template <typename Suite>
class SharedServerTest : public ::testing::Test {
 protected:
  static std::vector<std::string> ServerFlags() { return {}; }

  static void SetUpTestSuite() {
    auto server = ServerProcess::Start(Suite::ServerFlags());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  void SetUp() override {
    ASSERT_NE(server_, nullptr);
    client_ = std::make_unique<client::RiskplanClient>(server_->Channel());
  }

  static inline ServerProcess* server_ = nullptr;
  std::unique_ptr<client::RiskplanClient> client_;
};

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_SHARED_SERVER_TEST_H_
